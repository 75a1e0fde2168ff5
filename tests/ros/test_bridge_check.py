"""``attitude-bridge-check``: the conformance check of a hardware-in-the-loop bridge.

(1) The pure checker (``attitude_conformance.checker``) and the script (``.driver``) on
synthetic recordings: the project's own :class:`SimStepper` played in simulated time as
the bridge, correct and with one fault each. (2) The real tool against the real
``rigid_body_sim`` in both time modes. (3) The real tool against three broken bridges
(``tests/broken_bridges/``), each failing on its point. Real processes run on a reserved
``ROS_DOMAIN_ID`` (conftest.py).
"""

from __future__ import annotations

import importlib
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import run_bridge_check
from support import needs_workspace

from attitude_core.config.node_parameters import SIMULATOR
from attitude_core.config.parameters import values_from
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_core.models.mrp import quat_from_mrp
from attitude_core.runtime.sim_stepper import Action, SimStepper
from attitude_tools.run import bridge_check

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
BROKEN = ROOT / "tests" / "broken_bridges"
pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    needs_workspace,
]

sys.path.insert(0, str(ROOT / "src" / "attitude_conformance"))  # an ament package: from source
checker = importlib.import_module("attitude_conformance.checker")
procs = importlib.import_module("attitude_conformance.checks_process")
driver_mod = importlib.import_module("attitude_conformance.driver")
record = importlib.import_module("attitude_conformance.record")
Sample = record.Sample

TICK_S = 0.01  # simulated wall-time resolution of the synthetic runs
LATENCY_S = 0.002  # torque transport delay of the synthetic runs


LOCKSTEP, REALTIME = TimeMode.LOCKSTEP.value, TimeMode.REALTIME.value


class SyntheticBridge:
    """:class:`SimStepper` (the simulator's logic) in simulated wall time, recorded as the
    tool's node records; ``fault`` breaks it one way: ``frame``, ``stamp`` (+ one dt),
    ``wxyz``, ``late`` (each torque applied one step late), ``clock`` (a /clock in real
    time), ``no_resend``, ``hold_forever``, ``applied`` (wrong applied torque)."""

    def __init__(self, mode: str, fault: str | None = None) -> None:
        self.scenario = load_scenario(CASE1)
        given = {"time_mode": mode}
        if fault == "hold_forever":
            given["lockstep.max_held_steps"] = 1000
        params = SIMULATOR.typed(values_from(SIMULATOR.own, given, "test"))
        self.stepper = SimStepper.from_scenario(self.scenario, params, created=0.0)
        self.rec = record.Recording(record.Setup.from_scenario(self.scenario, mode))
        self.driver = driver_mod.Driver(self.rec)
        self.fault, self.mode = fault, mode
        self.dt_ns = self.rec.setup.dt_ns
        self.state = None
        self.inbox: list[tuple[float, int, np.ndarray]] = []
        self.previous_torque = np.zeros(3)

    # what the bridge publishes, as the node records it
    def publish(self, d, t: float) -> None:
        if d.applied is not None and d.applied_stamp_ns is not None:
            u = d.applied + (0.5 if self.fault == "applied" else 0.0)
            self.rec.applied.append(Sample(d.applied_stamp_ns, "body", tuple(u), t))
        if d.state is not None:
            self.state = d.state
        if d.state is None and not d.resend:
            return
        if self.fault == "no_resend" and d.resend:
            return
        s = self.state
        stamp = s.stamp_ns + (self.dt_ns if self.fault == "stamp" else 0)
        if s.clock_ns is not None or self.fault == "clock":
            self.rec.clock.append(Sample(s.k * self.dt_ns, "", (), t))
        x, y, z, w = quat_from_mrp(s.sigma_bn)
        q = (w, x, y, z) if self.fault == "wxyz" else (x, y, z, w)
        frame = "body" if self.fault == "frame" else "inertial"
        self.rec.attitude.append(Sample(stamp, frame, tuple(float(v) for v in q), t))
        self.rec.rate.append(Sample(stamp, "body", tuple(float(v) for v in s.omega_b), t))
        self.send(self.driver.on_state(stamp, t), t)

    def send(self, torques, t: float) -> None:
        for stamp, u in torques:
            self.rec.torques.append(Sample(stamp, "body", tuple(float(v) for v in u), t))
            self.inbox.append((t + LATENCY_S, stamp, np.array(u)))

    def deliver(self, t: float) -> None:
        due = [m for m in self.inbox if m[0] <= t]
        self.inbox = [m for m in self.inbox if m[0] > t]
        for _, stamp, u in due:
            if self.fault == "late":
                u, self.previous_torque = self.previous_torque, u
            self.publish(self.stepper.on_torque(t, stamp, u), t)

    def run(self, limit_s: float = 60.0):
        n, t = 0, 0.0
        d = self.stepper.poll_graph(t, True)
        while d.action is not Action.START:
            n += 1
            t = n * TICK_S
            d = self.stepper.poll_graph(t, True)
        self.publish(d if self.mode == LOCKSTEP else self.stepper.on_timer(t, int(t * 1e9)), t)
        ticks_per_step = round(self.rec.setup.dt_s / TICK_S)
        next_tick = n + ticks_per_step
        while not self.driver.done and t < limit_s:
            n += 1
            t = n * TICK_S
            self.deliver(t)
            if self.mode == LOCKSTEP:
                self.publish(self.stepper.on_timer(t), t)
            elif n == next_tick:
                next_tick += ticks_per_step
                self.publish(self.stepper.on_timer(t, int(t * 1e9)), t)
            self.send(self.driver.on_tick(t), t)
        return self.rec


def results(rec) -> dict:
    return {r.point: r for r in checker.judge(rec)}


def test_plant_point_names_the_node_a_run_adopts():
    checks_process = importlib.import_module("attitude_conformance.checks_process")
    TopicQos = checks_process.TopicQos

    def graph(att, rate):
        e = lambda n: (n, "RELIABLE", "VOLATILE")
        return [TopicQos("/spacecraft/attitude", "publisher", True, 1, [], [e(n) for n in att]),
                TopicQos("/spacecraft/angular_velocity", "publisher", True, 1, [],
                         [e(n) for n in rate])]  # fmt: skip

    one = checks_process.check_plant(graph(["/b"], ["/b"]))
    assert one.status == "PASS" and "--plant-node /b" in one.detail
    two = checks_process.check_plant(graph(["/b", "/x/b"], ["/x/b", "/b"]))
    assert two.status == "FAIL" and "/b, /x/b" in two.detail
    split = checks_process.check_plant(graph(["/att"], ["/rate"]))
    assert split.status == "SKIP" and "--plant-node /att --plant-node /rate" in split.detail
    assert checks_process.check_plant(graph([], ["/b"])).status == "SKIP"


def synthetic(mode: str, fault: str | None = None) -> dict:
    return results(SyntheticBridge(mode, fault).run())


def assert_all_pass(res: dict, skipped=()) -> None:
    bad = {p: r.line() for p, r in res.items() if r.status != ("SKIP" if p in skipped else "PASS")}
    assert not bad, bad


def plain(mode: str, attitude, rate, torques=()) -> object:
    """A recording from plain ``(stamp, frame, values)`` tuples."""
    rec = record.Recording(record.Setup.from_scenario(load_scenario(CASE1), mode))
    rec.attitude = [Sample(*m) for m in attitude]
    rec.rate = [Sample(*m) for m in rate]
    rec.torques = [Sample(*m) for m in torques]
    return rec


# --- (1) the checker on synthetic recordings ------------------------------------------


@pytest.mark.parametrize("mode", [LOCKSTEP, REALTIME])
def test_checker_passes_the_simulators_own_stepping(mode):
    res = synthetic(mode)
    assert_all_pass(res, skipped=("resend", "wheels") if mode == REALTIME else ("wheels",))
    assert list(res) == [p for p in record.POINTS if p not in ("qos", "plant", "sigint")]


@pytest.mark.parametrize(
    "mode, fault, point, words",
    [
        (LOCKSTEP, "frame", "frames", "attitude: 58 of 58 messages in frame 'body'"),
        (REALTIME, "frame", "frames", "expected 'inertial'"),
        (LOCKSTEP, "stamp", "stamps", "first state stamped 100000000 ns (0.1 s), expected 0"),
        (LOCKSTEP, "wxyz", "quaternion", "order or convention: published (w, x, y, z)"),
        (REALTIME, "wxyz", "quaternion", "order or convention"),
        (LOCKSTEP, "late", "torque_step", "the torque is applied one step late"),
        (REALTIME, "late", "torque_step", "the torque is applied one step late"),
        (REALTIME, "clock", "clock", "the contract has /clock only in lockstep"),
        (LOCKSTEP, "no_resend", "resend", "no re-send"),
        (LOCKSTEP, "hold_forever", "stale", "with the zero torque"),
        (LOCKSTEP, "applied", "applied_torque", "applied (0.52, 0.49, 0.508415) N m"),
    ],
)
def test_checker_fails_a_broken_bridge_naming_the_point(mode, fault, point, words):
    res = synthetic(mode, fault)
    assert res[point].status == "FAIL", res[point].line()
    assert res[point].line().startswith(f"FAIL {point}: ")
    assert words in res[point].detail, res[point].detail


def test_checker_fails_only_frames_on_a_wrong_frame():
    res = synthetic(LOCKSTEP, "frame")
    assert {p for p, r in res.items() if r.status == "FAIL"} == {"frames"}


def test_checker_judges_plain_tuples_stamps_off_by_one_step_and_unpaired():
    q, w = tuple(quat_from_mrp(load_scenario(CASE1).initial_mrp)), (0.0, 0.0, 0.0)
    dt = 100_000_000
    gap = plain(LOCKSTEP, [(0, "inertial", q), (dt, "inertial", q), (3 * dt, "inertial", q)], [])
    gap.rate = [Sample(s.stamp_ns, "body", w) for s in gap.attitude]
    assert "state 2 stamped 300000000 ns (0.3 s), expected k dt = 200000000 ns" in (
        checker.judge(gap)[0].detail
    )
    unpaired = plain(
        LOCKSTEP,
        [(0, "inertial", q), (dt, "inertial", q), (2 * dt, "inertial", q)],
        [(0, "body", w), (2 * dt, "body", w)],
    )
    assert checker.judge(unpaired)[0] == (
        "stamps",
        "FAIL",
        "attitude stamps without a rate of the same stamp: 100000000 ns (0.1 s)",
    )
    backwards = plain(REALTIME, [(5, "inertial", q), (4, "inertial", q)], [(5, "body", w)])
    assert "stamp went back: 4 ns" in checker.judge(backwards)[0].detail


def test_checker_names_an_inverse_rotation_and_a_wrong_initial_attitude():
    x, y, z, w = quat_from_mrp(load_scenario(CASE1).initial_mrp)
    inverse = plain(LOCKSTEP, [(0, "inertial", (-x, -y, -z, w))], [(0, "body", (0.0,) * 3)])
    assert "order or convention: the inverse rotation" in checker.judge(inverse)[3].detail
    other = plain(LOCKSTEP, [(0, "inertial", (0.0, 0.0, 0.0, 1.0))], [(0, "body", (0.0,) * 3)])
    assert "not the scenario's initial attitude" in checker.judge(other)[3].detail
    unnormed = plain(LOCKSTEP, [(0, "inertial", (x, y, z, 1.1 * w))], [(0, "body", (0.0,) * 3)])
    assert checker.judge(unnormed)[3].detail.startswith("norm 1.0")


def test_applied_torque_is_skipped_when_never_published():
    rec = SyntheticBridge(LOCKSTEP).run()
    rec.applied = []
    res = results(rec)
    assert res["applied_torque"].status == "SKIP"
    assert_all_pass(res, skipped=("applied_torque", "wheels"))


def test_script_torques_and_an_aborted_script():
    torques = [driver_mod.torque(i) for i in range(40)]
    assert all(np.any(u) for u in torques[:20] + torques[30:])
    assert not any(np.any(u) for u in torques[20:30])
    assert all(not np.array_equal(a, b) for a, b in zip(torques[:19], torques[1:20], strict=True))
    rec = SyntheticBridge(LOCKSTEP, "stamp").run()
    assert rec.aborted.startswith("no new state within 1.5")
    res = results(rec)
    assert res["torque_step"].detail.startswith("script stopped after 0 steps: no new state")


def test_qos_verdicts():
    topic = procs.TopicQos
    ok = [
        topic("/spacecraft/attitude", "publisher", True, 1, [], [("sim", "RELIABLE", "VOLATILE")]),
        topic("/controller/torque", "subscription", True, 1, [], [("sim", "RELIABLE", "VOLATILE")]),
    ]
    assert procs.check_qos(ok).status == "PASS"
    incompatible = [
        topic(
            "/spacecraft/attitude",
            "publisher",
            True,
            0,
            ["RELIABILITY"],
            [("sim", "BEST_EFFORT", "VOLATILE")],
        )
    ]
    verdict = procs.check_qos(incompatible)
    assert verdict.status == "FAIL" and "incompatible QoS (RELIABILITY)" in verdict.detail
    assert "sim BEST_EFFORT/VOLATILE" in verdict.detail
    # A best-effort state driver can still be connected: the verdict says how.
    hint = "qos_overrides./spacecraft/attitude.subscription.reliability:=best_effort"
    assert hint in verdict.detail
    missing = procs.check_qos([topic("/spacecraft/attitude", "publisher", True)], "7")
    assert missing.detail == (
        "/spacecraft/attitude: no publisher matched on ROS_DOMAIN_ID 7 (no publisher in the graph)"
    )
    lossy = [topic("/controller/torque", "subscription", True, 1, [], [("b", "BEST_EFFORT", "V")])]
    assert "the contract is reliable" in procs.check_qos(lossy).detail
    assert "qos_overrides" not in procs.check_qos(lossy).detail  # not a state topic


def test_sigint_verdicts_and_summary():
    check = procs.check_sigint
    assert check(False, None, None, 0.0, "").status == "SKIP"
    assert check(True, None, 0, 0.3, "ok").status == "PASS"
    assert check(True, None, None, 5.0, "").detail.startswith("still running 5 s after SIGINT")
    assert check(True, None, 1, 0.3, "").detail == "exit code 1 after SIGINT, expected 0"
    assert "Traceback" in check(True, None, 0, 0.3, "Traceback (most recent call last)").detail
    assert check(True, 2, None, 0.0, "").detail == "the bridge exited by itself with code 2"
    results_ = [record.Result("a", "PASS", ""), record.Result("b", "FAIL", "")]
    assert record.summary(results_, "lockstep") == (
        "SUMMARY FAIL: 1 passed, 1 failed, 0 skipped (lockstep); failed: b"
    )


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["--mode", "sometimes"],
        ["--mode", "lockstep", "--scenario", "/nonexistent.yaml"],
        ["--mode", "lockstep", "--scenario", str(ROOT / "tests/bad_scenarios/dt_zero.yaml")],
        ["--mode", "lockstep", "--timeout-s", "0"],
        ["--mode", "lockstep", "--launch", ""],
        ["--mode", "lockstep", "--launch", "'unclosed"],
    ],
)
def test_front_end_exits_2_on_bad_arguments(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        bridge_check.main(argv)
    assert exc.value.code == 2
    assert "attitude-bridge-check: error:" in capsys.readouterr().err


def test_front_end_passes_the_arguments_as_ros_parameters():
    args = bridge_check.parse(["--mode", "realtime", "--launch", 'run "it\'s"', "--timeout-s", "9"])
    cmd = bridge_check.node_command("ros2", args)
    assert cmd[:5] == ["ros2", "run", "attitude_conformance", "bridge_check", "--ros-args"]
    assert cmd[5:7] == ["-p", "mode:=realtime"]
    assert cmd[-4:] == ["-p", "timeout_s:=9.0", "-p", "launch:='run \"it''s\"'"]


# --- (2), (3) the real tool, real processes ---------------------------------------------


def run_check(env: dict, mode: str, launch: str) -> tuple[int, dict[str, str], list[str]]:
    """The tool on the default scenario: (exit code, line per point, all stdout lines)."""
    return run_bridge_check(env, mode, launch)


@pytest.mark.parametrize("mode", [LOCKSTEP, REALTIME])
@pytest.mark.parametrize(
    "bridge",
    ["ros2 run spacecraft_sim rigid_body_sim", "ros2 run spacecraft_bridge_example bridge"],
    ids=["rigid_body_sim", "example_bridge"],
)
def test_bridges_pass_every_point(ros_env, mode, bridge):
    """The project's simulator and the example bridge (another integrator, written from
    docs/hil_bridge.md alone) both meet the contract."""
    code, by_point, lines = run_check(ros_env(), mode, bridge)
    assert list(by_point) == list(record.POINTS), lines
    skipped = {"resend", "wheels"} if mode == REALTIME else {"wheels"}  # no wheels.* in case1
    for point, line in by_point.items():
        assert line.startswith("SKIP" if point in skipped else "PASS"), lines
    assert code == 0 and lines[-1].startswith("SUMMARY PASS"), lines


@pytest.mark.parametrize(
    "script, point, words",
    [
        ("wrong_frame.py", "frames", "in frame 'body', expected 'inertial'"),
        ("shifted_stamps.py", "stamps", "first state stamped 100000000 ns (0.1 s), expected 0"),
        ("quaternion_wxyz.py", "quaternion", "order or convention"),
        ("best_effort_state.py", "qos", "incompatible QoS (RELIABILITY)"),
    ],
)
def test_broken_bridge_fails_on_its_point(ros_env, script, point, words):
    launch = f"{shlex.quote(sys.executable)} {shlex.quote(str(BROKEN / script))}"
    code, by_point, lines = run_check(ros_env(), LOCKSTEP, launch)
    assert code == 1, lines
    assert by_point[point].startswith(f"FAIL {point}: ") and words in by_point[point], lines
    assert lines[-1].startswith("SUMMARY FAIL") and point in lines[-1].split("failed: ")[1]
    assert by_point["sigint"].startswith("PASS sigint"), lines  # the wrappers stop cleanly
    if script == "wrong_frame.py":  # one fault, one failing point
        assert [p for p, line in by_point.items() if line.startswith("FAIL")] == ["frames"]


# --- the link point on plain recordings -------------------------------------------------


def _realtime_link(gap_at: int | None = None, latency_s: float = 0.05, gap: int = 10) -> object:
    """A real-time recording of 100 states at 10 Hz received ``latency_s`` late on this
    host's clock (offset 1000 s from its monotonic clock), ``gap`` states lost from
    ``gap_at``."""
    states = [k for k in range(100) if gap_at is None or not gap_at <= k < gap_at + gap]
    base = 5_000_000_000
    att = [(base + k * 100_000_000, "inertial", (0.0, 0.0, 0.0, 1.0)) for k in states]
    rate = [(s, "body", (0.0, 0.0, 0.0)) for s, _, _ in att]
    rec = plain(REALTIME, att, rate)
    rec.system_offset_s = 1000.0  # receipt times on the monotonic clock, stamps on the system's
    rec.attitude = [a._replace(wall_s=a.stamp_ns * 1e-9 + latency_s - 1000.0) for a in rec.attitude]
    rec.rate = [r._replace(wall_s=r.stamp_ns * 1e-9 + latency_s - 1000.0) for r in rec.rate]
    return rec


def test_link_point_measures_latency_and_losses_against_the_watchdog():
    link_mod = importlib.import_module("attitude_conformance.checks_link")
    steps_mod = importlib.import_module("attitude_conformance.steps")
    rec = _realtime_link()
    ok = link_mod.check_link(rec, steps_mod.states(rec))
    assert ok.status == "PASS", ok.line()
    assert "latency 50.0 ms" in ok.detail and "0.0% of states lost" in ok.detail
    rec = _realtime_link(gap_at=40)
    gap = link_mod.check_link(rec, steps_mod.states(rec))
    assert gap.status == "PASS" and "longest wait 1.100 s" in gap.detail
    assert "10.0% of states lost" in gap.detail and "on its prediction" in gap.detail
    rec = _realtime_link(gap_at=40, gap=40)
    dead = link_mod.check_link(rec, steps_mod.states(rec))
    assert dead.status == "FAIL" and "would fly braking" in dead.detail
    rec = _realtime_link(latency_s=0.4)
    late = link_mod.check_link(rec, steps_mod.states(rec))
    assert late.status == "FAIL" and "latency 400.0 ms" in late.detail
