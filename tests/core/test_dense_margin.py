"""The dense margin of a run (``record.metrics.dense_min_margin_deg``) in both forms: with
the compiled screen (``ConeGeometry.dense_interval_minima``, kernels/metrics.pxi) and
with the NumPy reference alone (``dense_min_margin_deg_reference``). :class:`DenseChecks`
runs once with each form (CPython's ``heapq`` / ``_heapq`` way) on random trajectories
and geometries (property tests) and the summaries of the paper's cases; the module's
own test compares the forms to the bit."""

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from attitude_core import kernels
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.constraints import ConeGeometry, KeepInCones
from attitude_core.record import metrics, summary
from attitude_core.record.metrics import (
    DENSE_SLACK_DEG,
    dense_min_margin_deg,
    dense_min_margin_deg_reference,
)
from tests.support import MODE_SETTINGS, ROOT, KernelModeTests

needs_compiled = pytest.mark.skipif(
    kernels.built() is None, reason="the compiled kernels are not built (run tools/bootstrap)"
)


def _geometry(rng: np.random.Generator) -> ConeGeometry:
    n_i, n_j, n_k = rng.integers(1, 4), rng.integers(1, 7), rng.integers(0, 3)
    pair = rng.uniform(5.0, 40.0, (n_i, n_j))
    pair[rng.uniform(size=(n_i, n_j)) < 0.2] = np.nan  # pairs an instrument need not avoid
    pair[0, 0] = 20.0  # one constraint at least
    return ConeGeometry(
        rng.normal(size=(n_i, 3)),
        rng.uniform(5.0, 40.0, n_i),
        rng.normal(size=(n_j, 3)),
        samples=16,
        keep_in=KeepInCones(
            rng.normal(size=(n_k, 3)), rng.normal(size=(n_k, 3)), rng.uniform(40, 150, n_k)
        ),
        pair_angles_deg=pair if rng.uniform() < 0.5 else None,
    )


def _trajectory(
    rng: np.random.Generator, n: int, kind: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``t``, ``sigma_bn``, ``omega_b`` of ``n`` samples: a smooth slew (body rates
    integrated, shadow switches included), one that comes to rest (a long flat tail, as
    a settled run's), or unrelated attitudes and rates with uneven steps."""
    if kind == "random":
        t = np.cumsum(rng.uniform(0.01, 2.0, n))
        return t, Rotation.random(n, rng=rng).as_mrp(), rng.normal(scale=0.3, size=(n, 3))
    dt = 0.1 * (1.0 + 1e-3 * rng.uniform(-1.0, 1.0, n))
    t = np.cumsum(dt) - dt[0]
    w0, w1 = rng.normal(scale=0.1, size=3), rng.normal(scale=0.1, size=3)
    omega = w0 + np.outer(np.sin(np.linspace(0.0, 3.0, n)), w1)
    if kind == "rest":
        settle = np.exp(-np.linspace(0.0, 40.0, n))[:, None]
        omega = omega * settle + rng.normal(scale=1e-12, size=(n, 3))
    rot = [Rotation.random(rng=rng)]
    for k in range(n - 1):
        rot.append(rot[-1] * Rotation.from_rotvec(omega[k] * (t[k + 1] - t[k])))
    sigma = np.array([r.as_mrp() for r in rot])
    return t, sigma, omega


RANDOM_RUNS = (
    st.integers(0, 2**32 - 1),
    st.integers(2, 150),
    st.sampled_from(["smooth", "rest", "random"]),
    st.sampled_from([8, 8, 3, 5]),
)


class DenseChecks(KernelModeTests):
    """What the dense margin must give with each form."""

    @settings(max_examples=400, **MODE_SETTINGS)
    @given(*RANDOM_RUNS)
    def test_the_dense_margin_is_the_references_to_the_bit(self, seed, n, kind, substeps):
        """The result (margin and its time) is the reference's to the bit. With the
        compiled screen, its own smallest margin is within 1e-12 deg of it, and it keeps
        the reference's interval; without, there is no screen."""
        rng = np.random.default_rng(seed)
        g = _geometry(rng)
        t, sigma, omega = _trajectory(rng, n, kind)
        reference = dense_min_margin_deg_reference(g, t, sigma, omega, substeps)
        assert dense_min_margin_deg(g, t, sigma, omega, substeps) == reference
        q, q_dot = metrics._hermite_nodes(sigma, omega)
        basis = np.concatenate(metrics._hermite_basis(substeps), axis=0)[..., 0]
        screen = g.dense_interval_minima(t, q, q_dot, np.ascontiguousarray(basis), DENSE_SLACK_DEG)
        if self.mode == "python":
            assert screen is None  # no compiled screen: the reference measures it all
            return
        if screen is None:  # ill-conditioned at the minimum: the reference alone
            return
        smallest, per_interval = screen
        assert abs(smallest - reference[0]) <= 1e-12
        # Where the screen measured an interval, it is the reference's minimum there.
        kept = np.flatnonzero(per_interval <= smallest + DENSE_SLACK_DEG)
        for i in kept[:10]:
            ref_i = metrics._dense_min(g, t, q, q_dot, substeps, np.array([i]))[0]
            assert abs(per_interval[i] - ref_i) <= 1e-12
        span = t[-1] - t[0]
        first = int(np.searchsorted(t, reference[1], side="right")) - 1
        if reference[1] >= t[-1] - 1e-9 * span:
            first = n - 2  # the run's end, the last interval's
        assert first in kept or first - 1 in kept

    def test_a_constraint_met_end_on_is_measured_by_the_reference_alone(self):
        """Near 0 or 180 deg from a direction ``acos`` magnifies the cosine's rounding: the
        screen declines and the reference measures every interval."""
        g = ConeGeometry(np.array([[1.0, 0.0, 0.0]]), np.array([20.0]), np.array([[1.0, 0.0, 0.0]]))
        t = np.arange(5) * 0.1
        sigma = np.zeros((5, 3))
        omega = np.zeros((5, 3))
        q, q_dot = metrics._hermite_nodes(sigma, omega)
        basis = np.ascontiguousarray(np.concatenate(metrics._hermite_basis(8), axis=0)[..., 0])
        assert g.dense_interval_minima(t, q, q_dot, basis, DENSE_SLACK_DEG) is None
        assert dense_min_margin_deg(g, t, sigma, omega) == (-20.0, 0.0)
        q[2, 1] = math.nan
        assert g.dense_interval_minima(t, q, q_dot, basis, DENSE_SLACK_DEG) is None

    @pytest.mark.parametrize("scenario", ["case1", "case2", "keep_in", "two_instruments"])
    def test_summaries_are_the_references(self, scenario, monkeypatch):
        """The run's summary with this form is the one with the reference alone."""
        got = summary.summarize(_run(self.mode, scenario)).to_json()
        monkeypatch.setattr(summary, "dense_min_margin_deg", dense_min_margin_deg_reference)
        assert got == summary.summarize(_run(self.mode, scenario)).to_json()


@needs_compiled
class TestCompiledDense(DenseChecks):
    mode = "compiled"


class TestPythonDense(DenseChecks):
    mode = "python"


@functools.cache
def _run(mode: str, scenario: str):
    with kernels.selected(mode):
        return run_closed_loop(load_scenario(ROOT / f"scenarios/{scenario}.yaml"))


@needs_compiled
@pytest.mark.parametrize("scenario", ["case1", "case2", "keep_in", "two_instruments"])
def test_the_summaries_of_both_forms_are_the_same(scenario):
    """The run flown and summarised with the compiled kernels, and with the Python
    references: the same summary but for the wall-clock fields."""
    timing = {"wall_time_s", "planner_step_us_median", "planner_step_us_p99"}
    compiled, python = (
        {k: v for k, v in summary.summarize(_run(m, scenario)).to_json().items() if k not in timing}
        for m in ("compiled", "python")
    )
    assert compiled == python
