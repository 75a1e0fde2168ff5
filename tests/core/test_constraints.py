"""Keep-out geometry (eq. 5): exact margins and the MRP-space obstacle distance query,
checked against a brute-force dense sampling of the margin function."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from attitude_core.models.cone_math import unit_perpendicular
from attitude_core.models.constraints import ConeGeometry, KeepInCones
from attitude_core.models.mrp_obstacles import fiber_circles

PAPER = dict(
    boresights_body=[[1.0, 0.0, 0.0]],
    half_angles_deg=[20.0],
    directions_inertial=[[0.0, -0.981, -0.196], [-1.0, 0.0, 0.0], [0.958, 0.0, 0.287]],
)
TWO_INSTRUMENTS = dict(
    boresights_body=[[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]],
    half_angles_deg=[20.0, 12.0],
    directions_inertial=[
        [0.0, -0.981, -0.196],
        [-1.0, 0.0, 0.0],
        [0.6, 0.64, 0.48],
        [0.0, 0.0, -1.0],
    ],
)


def _margin_reference(geometry, sigma):
    """Margins straight from SciPy's rotation, independent of attitude_core.models.mrp."""
    c_bn = Rotation.from_mrp(sigma).as_matrix().swapaxes(-1, -2)
    b_n = np.einsum("...ki,nk->...ni", c_bn, geometry.boresights_body)
    cos = np.einsum("...ni,mi->...nm", b_n, geometry.directions_inertial)
    ang = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    return ang - geometry.half_angles_deg[:, None]


def test_margins_match_scipy_reference():
    g = ConeGeometry(**TWO_INSTRUMENTS)
    sig = np.random.default_rng(0).uniform(-1.2, 1.2, size=(500, 3))
    np.testing.assert_allclose(g.margins_deg(sig), _margin_reference(g, sig), atol=1e-7)
    single = np.array([g.min_margin_deg_single(s) for s in sig])
    np.testing.assert_allclose(single, g.min_margin_deg(sig), atol=1e-9)


def test_margin_sign_is_eq5():
    g = ConeGeometry(**PAPER)
    sig = np.random.default_rng(1).uniform(-1, 1, size=(2000, 3))
    c_bn = Rotation.from_mrp(sig).as_matrix().swapaxes(-1, -2)
    lhs = np.einsum("i,nij,mj->nm", g.boresights_body[0], c_bn, g.directions_inertial)
    violated = (lhs >= np.cos(np.radians(20.0))).any(axis=1)
    assert violated.any() and (~violated).any()
    np.testing.assert_array_equal(g.min_margin_deg(sig) <= 0.0, violated)


@pytest.mark.parametrize("spec", [PAPER, TWO_INSTRUMENTS])
def test_rim_circles_lie_on_the_region_boundary(spec):
    g = ConeGeometry(**spec, inflation_deg=2.0, samples=64)
    centres, normals, radii = g.rim_circles
    rng = np.random.default_rng(2)
    idx = rng.integers(0, len(radii), 400)
    t = rng.uniform(0, 2 * np.pi, 400)
    n = normals[idx]
    u = np.cross(n, [0.3, 0.5, 0.7])
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(n, u)
    pts = centres[idx] + radii[idx, None] * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v)
    # Every point of a rim circle has inflated margin 0 for its own pair, >= 0 overall is
    # not required (other regions may cover it), so check the owning pair.
    pair = idx // g.samples
    inst, obj = np.divmod(pair, g.n_objects)
    m = _margin_reference(g, pts)[np.arange(400), inst, obj]
    np.testing.assert_allclose(m, 2.0, atol=1e-7)


def _brute_force_distance(geometry, sigma, inflation):
    """Distance from sigma to {margin <= inflation} by dense grids in MRP space."""

    def violating(points):
        return _margin_reference(geometry, points).reshape(len(points), -1).min(1) <= inflation

    h = 0.02
    ax = np.arange(-1.0, 1.0 + h / 2, h)
    grid = sigma + np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3)
    dist = np.linalg.norm(grid - sigma, axis=1)
    bad = violating(grid)
    d_coarse = dist[bad].min()
    cands = grid[bad & (dist <= d_coarse + 0.04)]
    cands = cands[np.argsort(np.linalg.norm(cands - sigma, axis=1))][:300]
    hf = 0.003
    fax = np.arange(-0.024, 0.024 + hf / 2, hf)
    local = np.stack(np.meshgrid(fax, fax, fax, indexing="ij"), -1).reshape(-1, 3)
    best, best_pt = d_coarse, None
    for c in cands:
        pts = c + local
        ok = violating(pts)
        if ok.any():
            d = np.linalg.norm(pts[ok] - sigma, axis=1)
            if d.min() < best:
                best, best_pt = d.min(), pts[ok][np.argmin(d)]
    return best, best_pt


def _free_points(g, n, rng, lo=0.0, hi=1.0):
    out = []
    while len(out) < n:
        s = rng.normal(size=3)
        s *= rng.uniform(lo, hi) / np.linalg.norm(s)
        if g.min_margin_deg(s) > g.inflation_deg + 1.0:
            out.append(s)
    return out


# The inflated rim (20 + 2 deg about the object) passes exactly through the boresight's
# own direction, +x: one rim fibre holds the identity and is a line in MRP space.
RIM_THROUGH_BORESIGHT = dict(
    boresights_body=[[1.0, 0.0, 0.0]],
    half_angles_deg=[20.0],
    directions_inertial=[[np.cos(np.radians(22.0)), np.sin(np.radians(22.0)), 0.0]],
)


@pytest.mark.parametrize(
    "spec,seed", [(PAPER, 3), (TWO_INSTRUMENTS, 4), (RIM_THROUGH_BORESIGHT, 5)]
)
def test_obstacle_distance_matches_brute_force(spec, seed):
    g = ConeGeometry(**spec, inflation_deg=2.0)
    rng = np.random.default_rng(seed)
    for sigma in _free_points(g, 6, rng):
        q = g.closest_obstacle(sigma)
        ref, _ = _brute_force_distance(g, sigma, 2.0)
        assert q.distance > 0.0
        assert abs(q.distance - ref) < 0.01, (sigma, q.distance, ref)
        # The reported closest point is on the inflated boundary, at that distance.
        assert abs(g.min_margin_deg(q.closest_point) - 2.0) < 0.05
        assert abs(np.linalg.norm(q.closest_point - sigma) - q.distance) < 0.005
        np.testing.assert_allclose(np.linalg.norm(q.direction), 1.0, atol=1e-12)


def test_obstacle_seen_through_the_shadow_set():
    """Near |sigma| = 1 the closest region can lie across the unit sphere."""
    g = ConeGeometry(**PAPER, inflation_deg=0.0)
    rng = np.random.default_rng(5)
    checked = 0
    for sigma in _free_points(g, 200, rng, lo=0.95, hi=0.99):
        q = g.closest_obstacle(sigma)
        if np.linalg.norm(q.closest_point) > 1.0 + 1e-3:
            ref, ref_pt = _brute_force_distance(g, sigma, 0.0)
            assert abs(q.distance - ref) < 0.01
            # Same attitude region: the shadow of the closest point violates too.
            assert np.linalg.norm(ref_pt) > 1.0
            checked += 1
            if checked == 3:
                break
    assert checked == 3


def test_inside_region_is_negative():
    g = ConeGeometry(**PAPER)
    # Boresight pointed straight at object 2 ([-1,0,0]): 180 deg about b3.
    sigma = np.array([0.0, 0.0, 1.0])
    assert g.min_margin_deg(sigma) < 0
    q = g.closest_obstacle(sigma)
    assert q.distance < 0.0


# --- keep-in cones ----------------------------------------------------------------------

KEEP_IN = dict(  # deliberately not unit: the geometry normalises
    axes_body=np.array([[0.0, 0.7071, 0.7071], [0.0, 0.0, -2.0]]),
    directions_inertial=np.array([[0.2802, 0.7698, 0.5736], [0.3, -0.1, -0.9]]),
    max_angles_deg=np.array([70.0, 45.0]),
)


def _keep_in_reference(sigma, cones=KEEP_IN):
    """gamma_k - angle(a_k in inertial axes, d_k), the inertial axis from SciPy's active
    rotation of sigma_BN (R = C_BN^T), independent of attitude_core.models.mrp."""
    a = cones["axes_body"] / np.linalg.norm(cones["axes_body"], axis=1, keepdims=True)
    d = cones["directions_inertial"]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    rot = Rotation.from_mrp(sigma)
    out = []
    for k in range(len(a)):
        axis_n = rot.apply(a[k])  # (N, 3)
        ang = np.degrees(np.arccos(np.clip(axis_n @ d[k], -1.0, 1.0)))
        out.append(cones["max_angles_deg"][k] - ang)
    return np.stack(out, axis=-1)


def _with_keep_in(spec=TWO_INSTRUMENTS, **kw):
    return ConeGeometry(**spec, keep_in=KeepInCones(**KEEP_IN), **kw)


def test_keep_in_margins_match_scipy_reference():
    g = _with_keep_in(samples=16)
    sig = np.random.default_rng(10).uniform(-1.2, 1.2, size=(500, 3))
    ref = _keep_in_reference(sig)
    assert ref.min() < 0.0 < ref.max()  # both sides of the cones are sampled
    np.testing.assert_allclose(g.keep_in_margins_deg(sig), ref, atol=1e-7)
    # One attitude at a time, and a leading shape kept.
    np.testing.assert_allclose(g.keep_in_margins_deg(sig[7]), ref[7], atol=1e-7)
    assert g.keep_in_margins_deg(sig.reshape(25, 20, 3)).shape == (25, 20, 2)


def test_keep_in_margin_is_the_allowed_angle_minus_the_axis_angle():
    """At the identity the body axes are the inertial axes: exact values."""
    g = ConeGeometry(
        np.zeros((0, 3)),
        np.zeros(0),
        np.zeros((0, 3)),
        samples=16,
        keep_in=KeepInCones(
            np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
            np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
            np.array([30.0, 30.0, 100.0]),
        ),
    )
    np.testing.assert_allclose(g.keep_in_margins_deg(np.zeros(3)), [30.0, -150.0, 10.0])
    # 90 deg about inertial z: body x points along inertial +y (SciPy: active rotation).
    quarter = np.array([0.0, 0.0, np.tan(np.pi / 8.0)])
    np.testing.assert_allclose(
        Rotation.from_mrp(quarter).apply([1.0, 0.0, 0.0]), [0, 1, 0], atol=1e-15
    )
    np.testing.assert_allclose(g.keep_in_margins_deg(quarter), [-60.0, -60.0, 10.0], atol=1e-9)


def test_constraint_margins_number_keep_out_pairs_then_keep_in_cones():
    g = _with_keep_in(samples=16)
    n_i, n_j = 2, 4
    assert (g.n_keep_out, g.n_keep_in, g.n_constraints) == (n_i * n_j, 2, n_i * n_j + 2)
    sig = np.random.default_rng(11).uniform(-1.0, 1.0, size=(300, 3))
    every = g.constraint_margins_deg(sig)
    assert every.shape == (300, n_i * n_j + 2)
    keep_out = _margin_reference(g, sig)
    for i in range(n_i):
        for j in range(n_j):
            np.testing.assert_allclose(every[:, i * n_j + j], keep_out[:, i, j], atol=1e-7)
    np.testing.assert_allclose(every[:, n_i * n_j :], _keep_in_reference(sig), atol=1e-7)
    # The smallest margin covers both kinds, in the array and the hot-path forms.
    smallest = np.minimum(keep_out.min(axis=(1, 2)), _keep_in_reference(sig).min(axis=1))
    np.testing.assert_allclose(g.min_margin_deg(sig), smallest, atol=1e-7)
    single = np.array([g.min_margin_deg_single(s) for s in sig])
    np.testing.assert_allclose(single, smallest, atol=1e-7)
    # Somewhere a keep-in cone is the binding constraint.
    assert np.any(_keep_in_reference(sig).min(axis=1) < keep_out.min(axis=(1, 2)))


def test_keep_in_arc_margin_matches_a_dense_scipy_slerp():
    """The closed-form smallest keep-in margin along the short eigenaxis rotation equals
    the minimum over a dense SciPy slerp between the two attitudes."""
    cones = {k: v[:1] for k, v in KEEP_IN.items()}
    g = ConeGeometry(
        np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), samples=16, keep_in=KeepInCones(**cones)
    )
    rng = np.random.default_rng(12)
    crossed = 0
    for _ in range(40):
        a, b = Rotation.random(2, rng=rng).as_mrp()
        path = Slerp([0.0, 1.0], Rotation.from_mrp([a, b]))(np.linspace(0.0, 1.0, 4001))
        dense = _keep_in_reference(path.as_mrp(), cones).min()
        assert g.arc_min_margin_deg_single(a, b) == pytest.approx(dense, abs=2e-3)
        ends = _keep_in_reference(np.array([a, b]), cones).min()
        crossed += dense < min(ends, 0.0) - 1.0  # the cone left between two ends
    assert crossed >= 3


def test_dense_margin_of_a_one_sample_run_is_that_samples_margin():
    """A run stopped after its first state (e.g. by a foreign publisher) has no interval
    to interpolate: its dense margin is the exact margin of the one attitude."""
    from pathlib import Path

    from attitude_core.config.scenario_loader import load_scenario
    from attitude_core.record.metrics import dense_min_margin_deg

    sc = load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "case1.yaml")
    geometry = sc.cone_geometry()
    margin, t_min = dense_min_margin_deg(
        geometry, np.array([0.0]), sc.initial_mrp[None, :], np.zeros((1, 3))
    )
    assert t_min == 0.0
    assert margin == pytest.approx(float(geometry.min_margin_deg(sc.initial_mrp[None, :])[0]))


def _rim_circles_one_call_per_rim(g: ConeGeometry):
    """The rim circles with one ``fiber_circles`` call per constraint (the plain form)."""
    k = g.samples
    phi = 2.0 * np.pi * np.arange(k) / k
    cones = [
        (g.boresights_body[i], g.directions_inertial[j], np.radians(beta + g.inflation_deg))
        for i, j, beta in zip(g.pair_instrument, g.pair_object, g.pair_angles_deg, strict=True)
    ] + [
        (a, d, np.radians(max(gamma - g.inflation_deg, 1e-3)))
        for a, d, gamma in zip(
            g.keep_in_axes_body,
            g.keep_in_directions_inertial,
            g.keep_in_max_angles_deg,
            strict=True,
        )
    ]
    out = []
    for s, c, beta in cones:
        e1 = unit_perpendicular(c)
        e2 = np.cross(c, e1)
        b = g._rim(c, e1, e2, beta, phi)
        if np.max(b @ s) > 1.0 - 1e-9:
            b = g._rim(c, e1, e2, beta, phi + np.pi / k)
        out.append(fiber_circles(s, b))
    return tuple(np.concatenate(x) for x in zip(*out, strict=True))


@pytest.mark.parametrize("seed", range(4))
def test_rim_circles_built_per_boresight_are_those_built_per_rim_to_the_bit(seed):
    rng = np.random.default_rng(seed)
    for trial in range(60):
        ni, nj = int(rng.integers(1, 4)), int(rng.integers(1, 7))
        s, c = rng.normal(size=(ni, 3)), rng.normal(size=(nj, 3))
        if trial % 7 == 0:  # an object on (or against) a boresight: the half-step rim
            c[0] = s[0] / np.linalg.norm(s[0]) * (1 if trial % 2 else -1)
        pairs = rng.uniform(5.0, 40.0, (ni, nj)) if trial % 3 == 0 else None
        if pairs is not None:
            pairs[0, 0] = np.nan  # a pair that is no constraint
        keep_in = None
        if trial % 5 == 0:
            keep_in = KeepInCones(rng.normal(size=(2, 3)), rng.normal(size=(2, 3)), [40.0, 70.0])
        g = ConeGeometry(
            s, rng.uniform(5.0, 40.0, ni), c, 2.0, int(rng.choice([16, 36, 180])), keep_in, pairs
        )
        if g.n_constraints == 0:
            continue
        for got, plain in zip(g.rim_circles, _rim_circles_one_call_per_rim(g), strict=True):
            np.testing.assert_array_equal(got, plain)


def test_a_geometry_used_for_its_exact_margins_only_builds_no_rim_circles():
    g = ConeGeometry(**TWO_INSTRUMENTS, inflation_deg=2.0, samples=180)
    g.min_margin_deg_single((0.1, -0.2, 0.3))
    g.arc_min_margin_deg_single((0.1, -0.2, 0.3), (0.0, 0.1, 0.2))
    assert not g._rims_built
    query = g.closest_obstacle((0.1, -0.2, 0.3))  # the first rim query builds them
    assert g._rims_built and np.isfinite(query.distance)
