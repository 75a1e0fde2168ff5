"""The compiled per-step kernels (gnc/_kernels.pyx) against their Python references:
on the paper's cases and on random states (property tests), and the whole closed loop
of Case 1 and Case 2 run with each (``ATTITUDE_KERNELS``)."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core.config.scenario import load_scenario
from attitude_core.gnc import kernels, mrp
from attitude_core.gnc.actuators import scale_to_bound
from attitude_core.gnc.constraints import ConeGeometry, KeepInCones
from attitude_core.gnc.control import PdGains, commanded_torque, pd_torque
from attitude_core.gnc.dynamics import RigidBody
from attitude_core.gnc.guidance import Guidance
from tests.support import ROOT

K = kernels.compiled
pytestmark = pytest.mark.skipif(
    K is None and os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
)

finite = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(finite, finite, finite)
rate = st.tuples(*[st.floats(-0.5, 0.5, allow_nan=False)] * 3)
CASES = ("case1", "case2", "keep_in", "two_instruments", "leo_two_instruments")


def test_the_compiled_kernels_are_built_and_used():
    """The install builds them: a test run never silently measures the Python path."""
    assert K is not None, "attitude_core.gnc._kernels is not built (run tools/bootstrap)"
    assert kernels.ACTIVE == "compiled"


def _inertia(rng: np.random.Generator) -> np.ndarray:
    """A random physical inertia (positive principal moments, triangle inequality)."""
    a, b = np.sort(rng.uniform(1.0, 20.0, 2))
    moments = np.array([a, b, rng.uniform(b - a + 0.5, a + b - 0.1)])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q @ np.diag(moments) @ q.T


@settings(max_examples=300, deadline=None)
@given(vec, rate, vec, rate, st.integers(0, 2**32 - 1), st.booleans())
def test_pd_command_matches_eq11_and_the_bound(sigma, omega, sigma_t, omega_t, seed, bounded):
    j = _inertia(np.random.default_rng(seed))
    gains = PdGains.from_inertia(j, 5.5, 3.1)
    bound = (0.05, 0.02, 0.08) if bounded else None
    reference, saturated = scale_to_bound(pd_torque(gains, sigma, omega, sigma_t, omega_t), bound)
    u1, u2, u3, sat = K.pd_command(
        gains.kp_flat, gains.kd_flat, sigma, omega, sigma_t, omega_t, bound
    )
    np.testing.assert_allclose((u1, u2, u3), reference, rtol=1e-12, atol=1e-12)
    if bound is not None and abs(float(np.max(np.abs(reference) / bound)) - 1.0) > 1e-12:
        assert sat == saturated
    np.testing.assert_array_equal(
        commanded_torque(gains, sigma, omega, sigma_t, omega_t, bound), (u1, u2, u3)
    )


@settings(max_examples=500, deadline=None)
@given(vec, vec)
def test_mrp_helpers_are_the_references_to_the_bit(sigma_a, sigma_b):
    assert mrp.angle_between_single(sigma_a, sigma_b) == mrp.angle_between_single_reference(
        sigma_a, sigma_b
    )
    assert mrp.relative_single(sigma_a, sigma_b) == mrp.relative_single_reference(sigma_a, sigma_b)
    assert mrp.angle_between_single(sigma_a, sigma_a) == 0.0


@settings(max_examples=300, deadline=None)
@given(vec, rate, st.tuples(*[st.floats(-0.2, 0.2)] * 3), st.integers(0, 2**32 - 1))
def test_rk4_step_is_the_reference_to_the_bit(sigma, omega, torque, seed):
    j = _inertia(np.random.default_rng(seed))
    a = RigidBody(j, sigma, omega)
    b = RigidBody(j, sigma, omega)
    for dt in (0.1, 0.01, 0.5):
        a.step(torque, dt)
        b.step_reference(torque, dt)
        np.testing.assert_array_equal(a.sigma_bn, b.sigma_bn)
        np.testing.assert_array_equal(a.omega_b, b.omega_b)
    assert np.linalg.norm(a.sigma_bn) <= 1.0  # the shadow switch, eq. 2


def _random_geometry(rng: np.random.Generator) -> ConeGeometry:
    n_i, n_j, n_k = rng.integers(1, 4), rng.integers(1, 7), rng.integers(0, 3)
    pair = rng.uniform(5.0, 40.0, (n_i, n_j))
    pair[rng.uniform(size=(n_i, n_j)) < 0.2] = np.nan  # pairs an instrument need not avoid
    return ConeGeometry(
        rng.normal(size=(n_i, 3)),
        rng.uniform(5.0, 40.0, n_i),
        rng.normal(size=(n_j, 3)),
        inflation_deg=float(rng.uniform(0.0, 3.0)),
        samples=int(rng.integers(8, 90)),
        keep_in=KeepInCones(
            rng.normal(size=(n_k, 3)), rng.normal(size=(n_k, 3)), rng.uniform(40, 120, n_k)
        ),
        pair_angles_deg=pair if rng.uniform() < 0.5 else None,
    )


def _geometries() -> list[ConeGeometry]:
    rng = np.random.default_rng(7)
    out = [Guidance.from_scenario(load_scenario(ROOT / f"scenarios/{c}.yaml")).planner.geometry
           for c in CASES]  # fmt: skip
    return out + [_random_geometry(rng) for _ in range(40)]


GEOMETRIES = _geometries()


@pytest.mark.parametrize("index", range(len(GEOMETRIES)))
def test_margins_and_rim_search_match_the_reference(index):
    g = GEOMETRIES[index]
    g.rim_circles  # noqa: B018 -- built: the kernel's rim search with them
    assert g._kernel is not None
    rng = np.random.default_rng(index)
    sig = rng.uniform(-1.0, 1.0, (300, 3))
    sig = np.vstack([sig, sig[:20] * 1e-9, np.zeros((1, 3))])
    for a, b in zip(sig, np.roll(sig, 1, axis=0), strict=True):
        assert g.min_margin_deg_single(a) == g.min_margin_deg_single_reference(a)
        arc, arc_ref = (
            g.arc_min_margin_deg_single(a, b),
            g.arc_min_margin_deg_single_reference(a, b),
        )
        assert arc == arc_ref
        near = a + rng.normal(scale=1e-7, size=3)  # short arcs: the closed form's edge
        assert g.arc_min_margin_deg_single(a, near) == (
            g.arc_min_margin_deg_single_reference(a, near)
        )
        idx, d2, dm, dp, jm, jp = g._kernel.closest_rim(a)
        ridx, rd2, rdm, rdp, rjm, rjp = g.closest_rim_reference(a)
        # Squared distances are differences of O(1) terms: equal to 1e-12 absolute.
        np.testing.assert_allclose((d2, dm, dp), (rd2, rdm, rdp), rtol=0, atol=1e-12)
        if idx != ridx:  # a tie to rounding only
            assert abs(g.rim_distances_sq(a)[idx] - rd2) <= 1e-12
        else:
            assert (jm, jp) == (rjm, rjp)
    # The exact margin is the vectorised one too.
    np.testing.assert_allclose(
        [g.min_margin_deg_single(s) for s in sig], g.min_margin_deg(sig), atol=1e-9
    )


def _full_scan(circles: np.ndarray, sigma) -> tuple[int, float]:
    """The nearest rim circle by a scan of every circle, in the compiled squared
    distance's operations and order (the first of equal distances)."""
    sx, sy, sz = (float(x) for x in sigma)
    s2 = sx * sx + sy * sy + sz * sz
    best, best_i = math.inf, 0
    for i, c in enumerate(circles.tolist()):
        dd = -2.0 * (c[0] * sx + c[1] * sy + c[2] * sz) + c[6]
        dd = dd + s2
        h = (c[3] * sx + c[4] * sy + c[5] * sz) - c[7]
        h = dd - h * h
        h = math.sqrt(h if h >= 0.0 else 0.0) * c[9]
        dd = (dd + c[8]) - h
        d2 = dd if dd > 0.0 else 0.0
        if d2 < best:
            best, best_i = d2, i
    return best_i, best


@pytest.mark.parametrize("index", range(0, len(GEOMETRIES), 3))
def test_the_pruned_rim_search_is_the_full_scan_to_the_bit(index):
    """The rim search skips rims and circles on an angle bound (``ConeKernel._nearest``):
    its answer is the scan of every circle's, index and distance, at random attitudes,
    on and near the rims (where the bound is tightest) and at the origin."""
    g = GEOMETRIES[index]
    g.rim_circles  # noqa: B018
    circles = np.column_stack([g._centres, g._normals, g._c_dot_c, g._c_dot_n, g._r2, g._two_radii])
    rng = np.random.default_rng(100 + index)
    rims = g._centres[rng.integers(0, len(g._centres), 40)]  # circle centres: far inside
    pick = rng.integers(0, len(g._centres), 60)  # points on circles, and just off them
    normal = g._normals[pick]
    radial = np.cross(normal, rng.normal(size=(60, 3)))
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    on = g._centres[pick] + g._radii[pick, None] * radial
    on = on[np.linalg.norm(on, axis=1) < 2.0]
    off = on + rng.normal(scale=1e-3, size=on.shape)
    points = np.vstack([rng.uniform(-1.0, 1.0, (100, 3)), rims, on, off, np.zeros((1, 3))])
    for sigma in points:
        idx, d2, *_ = g._kernel.closest_rim(sigma)
        assert (idx, d2) == _full_scan(circles, sigma)


def test_the_compiled_obstacle_query_is_the_reference():
    """The closest obstacle from the compiled rim search, parabola and closest point
    against ``closest_obstacle_single_reference`` (the rim distances differ from NumPy's
    matrix product in the last bits only)."""
    for g in GEOMETRIES[::2]:
        rng = np.random.default_rng(len(g._centres) if g._rims_built else 0)
        for sigma in rng.uniform(-1.0, 1.0, (100, 3)):
            d, direction, point, pair = g.closest_obstacle_single(sigma)
            rd, rdirection, rpoint, rpair = g.closest_obstacle_single_reference(sigma)
            if pair != rpair:  # a tie to rounding between two rims
                assert abs(d - rd) <= 1e-9
                continue
            np.testing.assert_allclose(d, rd, rtol=0, atol=1e-9)
            np.testing.assert_allclose(direction, rdirection, rtol=0, atol=1e-6)
            np.testing.assert_allclose(point, rpoint, rtol=0, atol=1e-9)
            query = g.closest_obstacle(sigma)
            assert query.distance == d and query.constraint == pair
            assert tuple(query.direction) == direction


_LOOP = """
import json, sys
from attitude_core.closed_loop import run_closed_loop
from attitude_core.config.scenario import load_scenario
from attitude_core.gnc import kernels, mrp
r = run_closed_loop(load_scenario(sys.argv[1]))
print(json.dumps({"active": kernels.ACTIVE, "sigma": r.sigma_bn.tolist(),
    "omega": r.omega_b.tolist(), "torque": r.torque_b.tolist(), "sigma_t": r.sigma_t.tolist(),
    "omega_t": r.omega_t.tolist(), "status": r.planner_status.tolist()}))
"""


def _loop(scenario: str, choice: str) -> dict:
    env = dict(os.environ, **{kernels.ENV: choice})
    out = subprocess.run(
        [sys.executable, "-c", _LOOP, str(ROOT / f"scenarios/{scenario}.yaml")],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(out.stdout)


@pytest.mark.parametrize("scenario", ["case1", "case2"])
def test_closed_loop_is_the_reference_loop_within_1e12(scenario):
    """The whole run, compiled against the Python reference: the same statuses at every
    step and states within 1e-12 (the PD law's sums round in another order)."""
    compiled, reference = _loop(scenario, "compiled"), _loop(scenario, "python")
    assert (compiled["active"], reference["active"]) == ("compiled", "python")
    assert compiled["status"] == reference["status"]
    for key in ("sigma", "omega", "torque", "sigma_t", "omega_t"):
        np.testing.assert_allclose(compiled[key], reference[key], rtol=0, atol=1e-12, err_msg=key)


def test_a_bad_kernel_choice_is_named():
    env = dict(os.environ, **{kernels.ENV: "fortran"})
    out = subprocess.run(
        [sys.executable, "-c", "import attitude_core.gnc.kernels"],
        env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert out.returncode != 0
    assert "ATTITUDE_KERNELS='fortran'" in out.stderr and "expected" in out.stderr
