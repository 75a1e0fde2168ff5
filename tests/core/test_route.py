"""Global route (attitude_core.fsw.guidance.route): roadmap, continuous edge checks, completeness
against an independent search, infeasibility reasons; the guidance that follows it."""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation, Slerp

from attitude_core.assembly.guidance import guidance_from_scenario, route_planner
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance import guidance_routes
from attitude_core.fsw.guidance.guidance_routes import ROUTE_LATENCY_S
from attitude_core.fsw.guidance.route import RoutePlanner, roadmap, super_fibonacci_quaternions
from attitude_core.fsw.guidance.route_following import corner_speed
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.cone_math import short_rotation_single
from attitude_core.models.constraints import ConeGeometry
from attitude_core.models.mrp import angle_between_single, principal_angle, relative
from attitude_core.record.summary import summarize

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def _dense_margin_deg(geometry: ConeGeometry, sigma_a, sigma_b, n: int = 2001) -> float:
    """Smallest exact margin along the short rotation a -> b, sampled by SciPy's Slerp
    (independent of the closed form)."""
    ends = Rotation.from_mrp(np.stack([sigma_a, sigma_b]))
    path = Slerp([0.0, 1.0], ends)(np.linspace(0.0, 1.0, n))
    return float(geometry.min_margin_deg(path.as_mrp()).min())


def test_short_rotation_matches_scipy():
    rng = np.random.default_rng(3)
    for _ in range(200):
        a, b = Rotation.random(2, rng=rng)
        axis, angle = short_rotation_single(a.as_mrp(), b.as_mrp())
        rotvec = (b * a.inv()).as_rotvec()
        assert angle == pytest.approx(np.linalg.norm(rotvec), abs=1e-9)
        np.testing.assert_allclose(axis, rotvec / np.linalg.norm(rotvec), atol=1e-9)


def test_super_fibonacci_roadmap_covers_so3_evenly():
    q = super_fibonacci_quaternions(4096)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    rm = roadmap()
    probes = Rotation.random(20000, rng=np.random.default_rng(5)).as_quat()
    chord, _ = rm.tree.query(probes, k=1)
    gap_deg = np.degrees(4.0 * np.arcsin(chord / 2.0))  # rotation angle to the nearest node
    # Random attitudes of the same number leave far larger holes than the spiral.
    random_tree = cKDTree(np.concatenate([q := Rotation.random(4096, rng=7).as_quat(), -q]))
    random_gap = np.degrees(4.0 * np.arcsin(random_tree.query(probes, k=1)[0] / 2.0))
    assert gap_deg.max() < 15.0 < random_gap.max()
    # Every node has its neighbours; edges are the short rotations between their ends.
    degree = np.bincount(rm.edges.ravel(), minlength=rm.size)
    assert degree.min() >= 14
    r = rm.rotations
    rotvec = (r[rm.edges[:, 1]] * r[rm.edges[:, 0]].inv()).as_rotvec()
    np.testing.assert_allclose(rm.angles, np.linalg.norm(rotvec, axis=1), atol=1e-9)


def _random_geometry(rng, n_inst, n_obj):
    return ConeGeometry(
        rng.normal(size=(n_inst, 3)),
        rng.uniform(10.0, 35.0, n_inst),
        rng.normal(size=(n_obj, 3)),
        samples=16,
    )


def _free_end(geometry, rng, margin_deg):
    while True:
        sigma = Rotation.random(rng=rng).as_mrp()
        if geometry.min_margin_deg(sigma) > margin_deg:
            return sigma


def test_every_leg_keeps_the_clearance_all_along():
    """Every leg of every route keeps the route's clearance over the whole rotation,
    sampled densely by an independent slerp, not only at the waypoints."""
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(25):
        geometry = _random_geometry(rng, int(rng.integers(1, 4)), int(rng.integers(2, 7)))
        start, goal = _free_end(geometry, rng, 5.0), _free_end(geometry, rng, 5.0)
        route = RoutePlanner(geometry, 2.0).plan(start, goal)
        if not route.feasible:
            continue
        checked += 1
        wp = route.waypoints
        np.testing.assert_allclose(wp[0], start, atol=1e-12)
        assert angle_between_single(wp[-1], goal) < 1e-9
        legs = [angle_between_single(wp[i], wp[i + 1]) for i in range(len(wp) - 1)]
        assert route.rotation_rad == pytest.approx(sum(legs), abs=1e-9)
        assert route.rotation_rad >= angle_between_single(start, goal) - 1e-9
        for i in range(len(wp) - 1):
            assert _dense_margin_deg(geometry, wp[i], wp[i + 1]) >= route.clearance_deg - 1e-3
    assert checked >= 15


def _boresight_oracle(geometry, start, goal, buffer_deg, n=40000, k=10):
    """Independent feasibility for one instrument: its constraints depend only on where
    the boresight points (the roll about it is free), so a slew exists iff the
    boresight's free region of the sphere connects the start's and the goal's
    directions. A dense Fibonacci grid of the sphere, joined to its nearest neighbours."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + 5.0**0.5) * i
    pts = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    s = geometry.boresights_body[0]
    beta = geometry.half_angles_deg[0] + buffer_deg
    ang = np.degrees(np.arccos(np.clip(pts @ geometry.directions_inertial.T, -1, 1)))
    free = (ang > beta).all(axis=1)
    _, idx = cKDTree(pts).query(pts, k=k + 1)
    u = np.repeat(np.arange(n), k)
    v = idx[:, 1:].ravel()
    keep = free[u] & free[v]
    graph = coo_matrix((np.ones(keep.sum()), (u[keep], v[keep])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    ends = Rotation.from_mrp(np.stack([start, goal])).apply(s)
    a, b = cKDTree(pts).query(ends, k=1)[1]
    return bool(free[a] and free[b] and label[a] == label[b])


def test_route_exists_exactly_when_an_independent_search_finds_one():
    """Single-instrument slews, many of them enclosed: the roadmap finds a route exactly
    when the independent boresight-sphere search does (away from the resolution limit:
    the oracle must agree with itself 1 deg either side of the buffer)."""
    rng = np.random.default_rng(21)
    agree = infeasible = 0
    for _ in range(60):
        n_obj = int(rng.integers(18, 26))  # enough cones to enclose some ends
        geometry = ConeGeometry(
            [[1.0, 0.0, 0.0]], [rng.uniform(24.0, 32.0)], rng.normal(size=(n_obj, 3)), samples=16
        )
        start, goal = _free_end(geometry, rng, 5.0), _free_end(geometry, rng, 5.0)
        loose = _boresight_oracle(geometry, start, goal, 1.0)
        tight = _boresight_oracle(geometry, start, goal, 3.0)
        if loose != tight:
            continue  # a passage about as wide as the buffer: resolution-limited
        route = RoutePlanner(geometry, 2.0).plan(start, goal)
        assert route.feasible == loose, route.reason
        agree += 1
        infeasible += not loose
    assert agree >= 45 and infeasible >= 5


def test_enclosed_goal_is_infeasible_and_names_the_enclosing_cones():
    sc = load_scenario(SCENARIOS / "enclosed_goal.yaml")
    route = route_planner(sc, 2.0).plan(sc.initial_mrp, sc.desired_mrp)
    assert not route.feasible
    assert "goal is enclosed by" in route.reason
    assert set(route.blocking) == {f"star_tracker/object_{k}" for k in range(1, 5)}


def test_infeasible_slew_holds_the_start_and_says_why():
    sc = load_scenario(SCENARIOS / "enclosed_goal.yaml")
    run = run_closed_loop(sc)
    assert np.all(run.planner_status == PlannerStatus.INFEASIBLE.code)  # from the first step
    np.testing.assert_allclose(run.sigma_t, np.broadcast_to(sc.initial_mrp, run.sigma_t.shape))
    assert np.abs(run.torque_b).max() == 0.0
    s = summarize(run).to_json()
    assert s["planner_infeasible"] and not s["reached"] and not s["planner_stuck"]
    assert "star_tracker/object_1" in s["infeasible_reason"]
    assert s["route_rotation_deg"] is None


def test_shadow_crossing_slew_takes_the_short_way():
    """160 deg to 200 deg about z: 40 deg the short way across |sigma| = 1, not 320 deg
    through the origin of sigma_BN; the target stays continuous as an attitude."""
    sc = load_scenario(SCENARIOS / "shadow_crossing.yaml")
    run = run_closed_loop(sc)
    s = summarize(run).to_json()
    assert s["reached"] and s["min_margin_deg"] > 0.0
    assert s["rotation_deg"] == pytest.approx(40.0, abs=1.0)
    norms = np.linalg.norm(run.sigma_t, axis=1)
    assert norms.max() == pytest.approx(1.0, abs=0.01)  # the target crossed the shadow set
    steps = np.degrees(principal_angle(relative(run.sigma_t[1:], run.sigma_t[:-1])))
    assert steps.max() <= np.degrees(sc.actuators.max_rate_rad_s * sc.dt_s) + 1e-9
    # omega_t is in target axes: continuous across the switch, its change bounded by the
    # profile's acceleration (but for the landing on the goal, which zeroes a slow rate).
    change = np.linalg.norm(np.diff(run.omega_t, axis=0), axis=1)
    landing = (np.linalg.norm(run.omega_t[1:], axis=1) == 0.0) & (change > 0.0)
    alpha = guidance_from_scenario(sc).limits.accel_rad_s2
    assert change[~landing].max() <= alpha * sc.dt_s * 1.01  # hard braking caps: rounding
    assert landing.sum() == 1 and change[landing].max() < 2e-3


def _no_route(sc):
    return dataclasses.replace(sc, planner=dataclasses.replace(sc.planner, global_route=False))


def test_route_gets_past_where_the_fepf_alone_stalls():
    sc = load_scenario(SCENARIOS / "fepf_stall.yaml")
    alone = summarize(run_closed_loop(_no_route(sc))).to_json()
    assert alone["planner_stuck"] and not alone["reached"]
    routed = summarize(run_closed_loop(sc)).to_json()
    assert routed["reached"] and routed["min_margin_deg"] > 0.0
    assert routed["rotation_deg"] <= 1.05 * routed["route_rotation_deg"]


def _fly(guidance, sc, steps):
    from attitude_core.fsw.control.pd import PdGains, commanded_torque
    from attitude_core.world.rigid_body import RigidBody

    body = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
    gains = PdGains(sc.kp, sc.kd)
    targets = []
    for k in range(steps):
        out = guidance.update(k * sc.dt_s, body.sigma_bn, body.omega_b).target
        targets.append(out.sigma_t.copy())
        u = commanded_torque(
            gains, body.sigma_bn, body.omega_b, out.sigma_t, out.omega_t, sc.actuators.max_torque_nm
        )
        body.step(u, sc.dt_s)
    return np.array(targets), body


def _straight_route(sc):
    """A "route" straight through the cones: the FEPF alone then stalls against them."""
    route = route_planner(sc, 2.0).plan(sc.initial_mrp, sc.desired_mrp)
    return dataclasses.replace(
        route, waypoints=np.stack([sc.initial_mrp, sc.desired_mrp]), rotation_rad=0.0
    )


@pytest.mark.parametrize("threaded", [False, True])
def test_stalled_target_gets_a_new_route_off_the_step_path(threaded, monkeypatch):
    """Given a route straight through the cones, the FEPF stalls against them; the
    guidance plans a new route from the target (in a worker thread, or at once) and
    follows it ROUTE_LATENCY_S later. Without the new route the slew ends stuck."""
    sc = load_scenario(SCENARIOS / "fepf_stall.yaml")
    with monkeypatch.context() as m:
        m.setattr(guidance_routes, "ROUTE_REPLANS", 0)
        stalled = guidance_from_scenario(sc, initial_route=_straight_route(sc))
        _fly(stalled, sc, sc.n_steps)
    assert stalled.status == PlannerStatus.STUCK
    with ThreadPoolExecutor(max_workers=1) as pool:
        guidance = guidance_from_scenario(
            sc, executor=pool if threaded else None, initial_route=_straight_route(sc)
        )
        requested = []
        submit = guidance.executor.submit

        def spy(fn, *args):
            requested.append(guidance.t_prev)
            return submit(fn, *args)

        guidance.executor.submit = spy  # type: ignore[method-assign]
        _, body = _fly(guidance, sc, sc.n_steps)
    assert guidance.replans >= 1 and requested
    assert guidance.status == PlannerStatus.ARRIVED
    assert angle_between_single(body.sigma_bn, sc.desired_mrp) < math.radians(0.5)
    assert requested[0] + ROUTE_LATENCY_S <= sc.sim_time_s


def test_threaded_replan_flies_the_same_targets_as_the_immediate_one():
    sc = load_scenario(SCENARIOS / "fepf_stall.yaml")
    straight = _straight_route(sc)
    immediate, _ = _fly(guidance_from_scenario(sc, initial_route=straight), sc, 1500)
    with ThreadPoolExecutor(max_workers=1) as pool:
        threaded, _ = _fly(
            guidance_from_scenario(sc, executor=pool, initial_route=straight), sc, 1500
        )
    np.testing.assert_array_equal(immediate, threaded)


@pytest.mark.parametrize("turn_deg", [10.0, 45.0, 90.0, 150.0])
def test_corner_speed_keeps_the_swing_of_a_turn(turn_deg):
    """A point arriving at a corner at corner_speed, its velocity turned to the outgoing
    leg by at most alpha dt per step, stays within the allowed swing of that leg."""
    alpha, swing, dt = 1e-3, math.radians(0.5), 0.01
    turn = math.radians(turn_deg)
    v = corner_speed(alpha, turn, swing)
    d_out = np.array([math.cos(turn), math.sin(turn)])
    normal = np.array([-d_out[1], d_out[0]])
    p, vel = np.zeros(2), np.array([v, 0.0])
    worst = 0.0
    for _ in range(int(4.0 * v / alpha / dt) + 10):
        change = v * d_out - vel
        size = np.linalg.norm(change)
        vel = vel + (change if size <= alpha * dt else change * (alpha * dt / size))
        p = p + vel * dt
        worst = max(worst, abs(float(p @ normal)))
    assert worst <= swing * (1.0 + 1e-2)
    assert worst >= 0.5 * swing * math.cos(turn / 2.0)  # not needlessly slow either
