"""The dense margin of a run (``record.metrics.dense_min_margin_deg``): its compiled screen
(``ConeGeometry.dense_interval_minima``, gnc/_kernels.pyx) against the NumPy reference
(``dense_min_margin_deg_reference``) on random trajectories and geometries (property
tests), and the summaries of the paper's cases with either."""

import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from attitude_core.closed_loop import run_closed_loop
from attitude_core.config.scenario import load_scenario
from attitude_core.gnc import kernels
from attitude_core.gnc.constraints import ConeGeometry, KeepInCones
from attitude_core.record import metrics, summary
from attitude_core.record.metrics import (
    DENSE_SLACK_DEG,
    dense_min_margin_deg,
    dense_min_margin_deg_reference,
)
from tests.support import ROOT

pytestmark = pytest.mark.skipif(
    kernels.compiled is None and os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
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


@settings(max_examples=400, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(2, 150),
    st.sampled_from(["smooth", "rest", "random"]),
    st.sampled_from([8, 8, 3, 5]),
)
def test_the_dense_margin_is_the_references_to_the_bit(seed, n, kind, substeps):
    """The result (margin and its time) is the reference's to the bit; the screen's own
    smallest margin is within 1e-12 deg of it, and it keeps the reference's interval."""
    rng = np.random.default_rng(seed)
    g = _geometry(rng)
    t, sigma, omega = _trajectory(rng, n, kind)
    reference = dense_min_margin_deg_reference(g, t, sigma, omega, substeps)
    assert dense_min_margin_deg(g, t, sigma, omega, substeps) == reference
    q, q_dot = metrics._hermite_nodes(sigma, omega)
    basis = np.concatenate(metrics._hermite_basis(substeps), axis=0)[..., 0]
    screen = g.dense_interval_minima(t, q, q_dot, np.ascontiguousarray(basis), DENSE_SLACK_DEG)
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


def test_a_constraint_met_end_on_is_measured_by_the_reference_alone():
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
def test_summaries_are_the_references(scenario, monkeypatch):
    """The run's summary with the compiled screen is the one with the reference alone."""
    run = run_closed_loop(load_scenario(ROOT / f"scenarios/{scenario}.yaml"))
    got = summary.summarize(run).to_json()
    monkeypatch.setattr(summary, "dense_min_margin_deg", dense_min_margin_deg_reference)
    assert got == summary.summarize(run).to_json()
