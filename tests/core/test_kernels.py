"""The per-step kernels in both forms, compiled (kernels/*.pxi) and the Python references,
CPython's ``heapq`` / ``_heapq`` way: every check of :class:`KernelChecks` runs once with
each form (:class:`TestCompiledKernels`, :class:`TestPythonKernels`), on the paper's
cases and on random states (property tests); the module's own tests compare the two
forms to the bit, the whole closed loop of Case 1 and Case 2 included
(``attitude-offline`` with ``ATTITUDE_KERNELS=compiled`` and ``=python``)."""

import functools
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core import kernels
from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.fsw.control.pd import PdGains, commanded_torque, pd_torque
from attitude_core.fsw.control.saturation import scale_to_bound
from attitude_core.models import mrp
from attitude_core.models.constraints import ConeGeometry, KeepInCones
from attitude_core.world.rigid_body import RigidBody
from tests.support import MODE_SETTINGS, ROOT, KernelModeTests

finite = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(finite, finite, finite)
rate = st.tuples(*[st.floats(-0.5, 0.5, allow_nan=False)] * 3)
CASES = ("case1", "case2", "keep_in", "two_instruments", "leo_two_instruments")
N_RANDOM = 40
N_GEOMETRIES = len(CASES) + N_RANDOM
needs_compiled = pytest.mark.skipif(
    kernels.built() is None, reason="the compiled kernels are not built (run tools/bootstrap)"
)


@pytest.mark.skipif(
    os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
)
def test_the_compiled_kernels_are_built_and_used():
    """The install builds them: a test run never silently measures the Python path."""
    assert kernels.compiled is not None, (
        "attitude_core.kernels._kernels is not built (run tools/bootstrap)"
    )
    assert kernels.ACTIVE == "compiled"


def _inertia(rng: np.random.Generator) -> np.ndarray:
    """A random physical inertia (positive principal moments, triangle inequality)."""
    a, b = np.sort(rng.uniform(1.0, 20.0, 2))
    moments = np.array([a, b, rng.uniform(b - a + 0.5, a + b - 0.1)])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q @ np.diag(moments) @ q.T


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


@functools.cache
def geometries(mode: str) -> list[ConeGeometry]:
    """The paper's cases' and random geometries, made with the ``mode`` kernels (the same
    constraints in either mode)."""
    with kernels.selected(mode):
        rng = np.random.default_rng(7)
        out = [guidance_from_scenario(load_scenario(ROOT / f"scenarios/{c}.yaml")).planner.geometry
               for c in CASES]  # fmt: skip
        out += [_random_geometry(rng) for _ in range(N_RANDOM)]
    assert len(out) == N_GEOMETRIES
    return out


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


class KernelChecks(KernelModeTests):
    """What each form of the free kernels and of a geometry's queries must do."""

    @settings(max_examples=300, **MODE_SETTINGS)
    @given(vec, rate, vec, rate, st.integers(0, 2**32 - 1), st.booleans())
    def test_pd_command_matches_eq11_and_the_bound(
        self, sigma, omega, sigma_t, omega_t, seed, bounded
    ):
        j = _inertia(np.random.default_rng(seed))
        gains = PdGains.from_inertia(j, 5.5, 3.1)
        bound = (0.05, 0.02, 0.08) if bounded else None
        reference, saturated = scale_to_bound(
            pd_torque(gains, sigma, omega, sigma_t, omega_t), bound
        )
        u1, u2, u3, sat = self.K.pd_command(
            gains.kp_flat, gains.kd_flat, sigma, omega, sigma_t, omega_t, bound
        )
        np.testing.assert_allclose((u1, u2, u3), reference, rtol=1e-12, atol=1e-12)
        if bound is not None and abs(float(np.max(np.abs(reference) / bound)) - 1.0) > 1e-12:
            assert sat == saturated
        if bound is not None:
            assert np.all(np.abs((u1, u2, u3)) <= np.asarray(bound) * (1.0 + 1e-12))
        np.testing.assert_array_equal(
            commanded_torque(gains, sigma, omega, sigma_t, omega_t, bound), (u1, u2, u3)
        )

    @settings(max_examples=500, **MODE_SETTINGS)
    @given(vec, vec)
    def test_mrp_helpers_are_the_references_to_the_bit(self, sigma_a, sigma_b):
        k = self.K
        angle = k.angle_between(sigma_a, sigma_b)
        assert angle == mrp.angle_between_single_reference(sigma_a, sigma_b)
        relative = k.relative(sigma_a, sigma_b)
        assert relative == mrp.relative_single_reference(sigma_a, sigma_b)
        assert k.angle_between(sigma_a, sigma_a) == 0.0
        assert 0.0 <= angle <= math.pi
        assert math.hypot(*relative) <= 1.0 + 1e-12  # the short way

    @settings(max_examples=300, **MODE_SETTINGS)
    @given(vec, rate, st.tuples(*[st.floats(-0.2, 0.2)] * 3), st.integers(0, 2**32 - 1))
    def test_rk4_step_is_the_reference_to_the_bit(self, sigma, omega, torque, seed):
        j = _inertia(np.random.default_rng(seed))
        a = RigidBody(j, sigma, omega)  # made with this form: its step is this form's
        b = RigidBody(j, sigma, omega)
        for dt in (0.1, 0.01, 0.5):
            a.step(torque, dt)
            b.step_reference(torque, dt)
            np.testing.assert_array_equal(a.sigma_bn, b.sigma_bn)
            np.testing.assert_array_equal(a.omega_b, b.omega_b)
        assert np.linalg.norm(a.sigma_bn) <= 1.0  # the shadow switch, eq. 2

    def _rim_search(self, g: ConeGeometry):
        """This form's rim search: the compiled kernel's, or the reference's."""
        kernel = g.compiled_kernel(rims=True)
        assert (kernel is not None) == (self.mode == "compiled")
        return g.closest_rim_reference if kernel is None else kernel.closest_rim

    @pytest.mark.parametrize("index", range(N_GEOMETRIES))
    def test_margins_and_rim_search_match_the_reference(self, index):
        g = geometries(self.mode)[index]
        search = self._rim_search(g)
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
            # The nearest circle, its squared distance and its neighbours': the same bits.
            idx, d2, dm, dp, jm, jp = search(a)
            assert (idx, d2, dm, dp, jm, jp) == g.closest_rim_reference(a)
            assert d2 == g.rim_distances_sq(a)[idx] == g.rim_distances_sq(a).min()
        # The exact margin is the vectorised one too.
        np.testing.assert_allclose(
            [g.min_margin_deg_single(s) for s in sig], g.min_margin_deg(sig), atol=1e-9
        )

    @pytest.mark.parametrize("index", range(0, N_GEOMETRIES, 3))
    def test_the_rim_search_is_the_full_scan_to_the_bit(self, index):
        """The compiled rim search skips rims and circles on an angle bound
        (``ConeKernel._nearest``), the reference scans them all: either answer is the scan
        of every circle's, index and distance, at random attitudes, on and near the rims
        (where the bound is tightest) and at the origin."""
        g = geometries(self.mode)[index]
        search = self._rim_search(g)
        circles = np.column_stack(
            [g._centres, g._normals, g._c_dot_c, g._c_dot_n, g._r2, g._two_radii]
        )
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
            idx, d2, *_ = search(sigma)
            assert (idx, d2) == _full_scan(circles, sigma)

    def test_the_obstacle_query_is_the_reference(self):
        """The closest obstacle (rim search, parabola and closest point) against
        ``closest_obstacle_single_reference``, to the bit."""
        for g in geometries(self.mode)[::2]:
            g.rim_circles  # noqa: B018 -- built: the query runs the rim search
            rng = np.random.default_rng(len(g._centres))
            for sigma in rng.uniform(-1.0, 1.0, (100, 3)):
                got = g.closest_obstacle_single(sigma)
                assert got == g.closest_obstacle_single_reference(sigma)
                d, direction, point, pair = got
                inside = g.min_margin_deg_single(sigma) < g.inflation_deg
                assert (math.copysign(1.0, d) < 0.0) == inside  # negative inside a region
                assert 0 <= pair < g.n_constraints
                query = g.closest_obstacle(sigma)
                assert query.distance == d and query.constraint == pair
                assert tuple(query.direction) == direction


@needs_compiled
class TestCompiledKernels(KernelChecks):
    mode = "compiled"


class TestPythonKernels(KernelChecks):
    mode = "python"


# -- the two forms against each other ----------------------------------------------------


@needs_compiled
@settings(max_examples=500, deadline=None)
@given(vec, vec, vec, rate, rate, st.booleans())
def test_the_free_kernels_of_both_forms_agree_to_the_bit(a, b, c, wa, wb, bounded):
    """The compiled free functions, and the process's MRP helpers, against the Python
    references: the same bits."""
    from tests.support import kernel_functions

    compiled, python = kernel_functions("compiled"), kernel_functions("python")
    assert compiled.angle_between(a, b) == python.angle_between(a, b)
    assert mrp.angle_between_single(a, b) == mrp.angle_between_single_reference(a, b)
    assert compiled.relative(a, b) == python.relative(a, b)
    assert mrp.relative_single(a, b) == mrp.relative_single_reference(a, b)
    gains = PdGains.from_inertia(np.diag([3.0, 5.0, 4.0]) + 0.3, 5.5, 3.1)
    bound = (0.05, 0.02, 0.08) if bounded else None
    args = (gains.kp_flat, gains.kd_flat, a, wa, c, wb, bound)
    assert compiled.pd_command(*args) == python.pd_command(*args)


@needs_compiled
@pytest.mark.parametrize("index", range(0, N_GEOMETRIES, 2))
def test_a_geometry_of_either_form_answers_alike_to_the_bit(index):
    """The same constraints made with each form: the same margins, arcs and closest
    obstacles, bit for bit."""
    a, b = geometries("compiled")[index], geometries("python")[index]
    assert a.compiled_kernel() is not None and b.compiled_kernel() is None
    rng = np.random.default_rng(300 + index)
    sig = rng.uniform(-1.0, 1.0, (120, 3))
    for s, t in zip(sig, np.roll(sig, 1, axis=0), strict=True):
        assert a.min_margin_deg_single(s) == b.min_margin_deg_single(s)
        assert a.arc_min_margin_deg_single(s, t) == b.arc_min_margin_deg_single(s, t)
        assert a.closest_obstacle_single(s) == b.closest_obstacle_single(s)


_LOOP = """
import sys
import numpy as np
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.config.scenario_loader import load_scenario
from attitude_core import kernels
r = run_closed_loop(load_scenario(sys.argv[1]))
np.savez(sys.argv[2], sigma=r.sigma_bn, omega=r.omega_b, torque=r.torque_b, sigma_t=r.sigma_t,
    omega_t=r.omega_t, d_obs=r.obstacle_distance_mrp, status=r.planner_status)
print(kernels.ACTIVE)
"""
ATTITUDE_OFFLINE = str(Path(sys.prefix) / "bin" / "attitude-offline")
TIMING = {"wall_time_s", "planner_step_us_median", "planner_step_us_p99"}
"""The summary's wall-clock fields: the only ones that may differ between two runs."""


def _run(scenario: str, choice: str, out) -> tuple[dict, bytes, dict]:
    """The closed loop of ``scenario`` with the ``choice`` kernels, in subprocesses: its
    arrays (``run_closed_loop``), and ``attitude-offline``'s timeseries.csv and summary."""
    env = dict(os.environ, **{kernels.ENV: choice})
    path = str(ROOT / f"scenarios/{scenario}.yaml")
    arrays = out / f"{choice}.npz"
    done = subprocess.run(
        [sys.executable, "-c", _LOOP, path, str(arrays)],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert done.stdout.strip() == choice
    run_dir = out / choice
    subprocess.run(
        [ATTITUDE_OFFLINE, path, "--out", str(run_dir), "--quiet"],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    with np.load(arrays) as data:
        record = {k: data[k].tobytes() for k in data.files}
    summary = json.loads((run_dir / "summary.json").read_text())
    return record, (run_dir / "timeseries.csv").read_bytes(), summary


@needs_compiled
@pytest.mark.parametrize("scenario", ["case1", "case2"])
def test_the_closed_loop_is_the_same_to_the_bit_with_either_form(scenario, tmp_path):
    """The whole run, compiled against the Python references (``ATTITUDE_KERNELS``, each
    in its own process): every array of the record equal to the bit (so the same status
    at every step), and ``attitude-offline``'s ``timeseries.csv`` byte for byte, its
    summary but for the wall-clock fields."""
    compiled, csv_c, summary_c = _run(scenario, "compiled", tmp_path)
    python, csv_p, summary_p = _run(scenario, "python", tmp_path)
    assert compiled.keys() == python.keys()
    for key in compiled:
        assert compiled[key] == python[key], key
    assert csv_c == csv_p
    assert summary_c.keys() >= TIMING
    assert {k: v for k, v in summary_c.items() if k not in TIMING} == {
        k: v for k, v in summary_p.items() if k not in TIMING
    }


def test_a_bad_kernel_choice_is_named():
    env = dict(os.environ, **{kernels.ENV: "fortran"})
    out = subprocess.run(
        [sys.executable, "-c", "import attitude_core.kernels"],
        env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert out.returncode != 0
    assert "ATTITUDE_KERNELS='fortran'" in out.stderr and "expected" in out.stderr
    with (
        pytest.raises(ValueError, match="expected 'compiled' or 'python'"),
        kernels.selected("fortran"),
    ):
        pass


def test_a_selection_holds_for_its_block_and_what_is_made_in_it():
    before = kernels.compiled, kernels.ACTIVE
    with kernels.selected("python") as module:
        assert module is None and kernels.compiled is None and kernels.ACTIVE == "python"
        body = RigidBody(np.eye(3), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0))
        g = geometries("python")[0]
    assert (kernels.compiled, kernels.ACTIVE) == before
    assert g.compiled_kernel(rims=True) is None  # still the references
    ref = RigidBody(np.eye(3), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0))
    body.step((0.01, 0.0, 0.0), 0.1)
    ref.step_reference((0.01, 0.0, 0.0), 0.1)
    assert body.sigma_bn.tobytes() == ref.sigma_bn.tobytes()
