"""``attitude-bridge-check`` on wheel plants (scenarios with ``wheels.*``): the ``wheels``
point and the stepping points judged with the hub-and-wheel model.

(1) The pure checker and the script on synthetic recordings: a lockstep wheel plant
written from docs/hil_bridge.md on :class:`attitude_core.world.wheel_plant.WheelPlant`,
played in simulated time, correct and with one fault each. (2) The real tool against the
example bridge and ``rigid_body_sim`` on ``scenarios/case1_rw_pyramid.yaml`` in both time
modes, and against two broken wheel bridges (``tests/broken_bridges/wheel_*.py``), on a
reserved ``ROS_DOMAIN_ID``.
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

from attitude_core.config.scenario import Scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_core.models.mrp import quat_from_mrp
from attitude_core.models.wheel_array import RPM
from attitude_core.world.wheel_plant import WheelPlant

ROOT = Path(__file__).resolve().parents[2]
PYRAMID = ROOT / "scenarios" / "case1_rw_pyramid.yaml"
CASE1 = ROOT / "scenarios" / "case1.yaml"
BROKEN = ROOT / "tests" / "broken_bridges"
LOCKSTEP, REALTIME = TimeMode.LOCKSTEP.value, TimeMode.REALTIME.value

sys.path.insert(0, str(ROOT / "src" / "attitude_conformance"))  # an ament package: from source
checker = importlib.import_module("attitude_conformance.checker")
driver_mod = importlib.import_module("attitude_conformance.driver")
record = importlib.import_module("attitude_conformance.record")
Sample, JointSample = record.Sample, record.JointSample

TICK_S = 0.01  # simulated wall-time resolution
LATENCY_S = 0.002  # transport delay of the commands


def limited(tmp_path: Path) -> Scenario:
    """The pyramid with rw1 a step short of its speed limit and rw3 failing at 1.5 s."""
    text = PYRAMID.read_text().replace("initial_speed_rpm: 1500.0", "initial_speed_rpm: 5950.0")
    text = text.replace("      rw3:\n", "      rw3:\n        fails_at_s: 1.5\n")
    path = tmp_path / "limited.yaml"
    path.write_text(text)
    return load_scenario(path)


class SyntheticWheelBridge:
    """A lockstep wheel plant in simulated wall time (hold, then zero; re-sends), recorded
    as the tool's node records it. ``fault`` breaks it one way: ``ignore_rw2`` (rw2's
    command taken as zero), ``wheel_stamp`` (wheel states stamped one step late),
    ``missing_wheel`` (rw4 left out of the wheel states), ``rpm`` (speeds in rpm),
    ``unclipped`` (no torque limit), ``no_speed_limit``, ``positional`` (the command's
    arrays read by position), ``effort_late`` (the effort of the step before)."""

    def __init__(self, scenario: Scenario, fault: str | None = None) -> None:
        assert scenario.wheels is not None
        self.array = scenario.wheels
        self.rec = record.Recording(record.Setup.from_scenario(scenario, LOCKSTEP))
        self.driver = driver_mod.Driver(self.rec)
        self.fault = fault
        self.plant = WheelPlant(
            scenario.inertia_kgm2, self.array, scenario.initial_mrp, scenario.initial_rate_rad_s
        )
        limit = self.array.max_torque
        if fault == "unclipped":
            self.plant.applied = lambda u, t: np.asarray(u, dtype=float)  # type: ignore[method-assign]
        if fault == "no_speed_limit":  # clipped, zero once failed, but never refused
            self.plant.applied = lambda u, t: np.where(  # type: ignore[method-assign]
                self.plant.failed(t), 0.0, np.clip(u, -limit, limit)
            )
        self.dt_ns = self.rec.setup.dt_ns
        self.k = 0
        self.effort = self.previous_effort = np.zeros(len(self.array))
        self.inbox: list[tuple[float, int, list[str], list[float]]] = []

    def publish(self, t: float) -> None:
        """State k (first send or re-send): /clock, wheel states, attitude, rate."""
        stamp = self.k * self.dt_ns
        names, speeds = list(self.array.names), self.plant.speeds.copy()
        effort = self.previous_effort if self.fault == "effort_late" else self.effort
        if self.fault == "rpm":
            speeds = speeds / RPM
        n = len(names) - (self.fault == "missing_wheel")
        wheel_stamp = stamp + (self.dt_ns if self.fault == "wheel_stamp" else 0)
        joint = JointSample(
            wheel_stamp, "body", tuple(names[:n]), tuple(speeds[:n]), tuple(effort[:n]), t
        )
        self.rec.clock.append(Sample(stamp, "", (), t))
        self.rec.wheel_states.append(joint)
        q = quat_from_mrp(self.plant.sigma_bn)
        q = -q if q[3] < 0.0 else q
        self.rec.attitude.append(Sample(stamp, "inertial", tuple(float(v) for v in q), t))
        self.rec.rate.append(Sample(stamp, "body", tuple(float(v) for v in self.plant.omega_b), t))
        self.send(self.driver.on_state(stamp, t), t)

    def send(self, torques, t: float) -> None:
        """What the tool's node does with the driver's answers, the message in transit."""
        for stamp, u in torques:
            order = driver_mod.wheel_order(self.driver.index[stamp], len(self.array))
            self.rec.torques.append(Sample(stamp, "body", tuple(float(v) for v in u), t))
            if order != tuple(range(len(order))):
                self.rec.wheel_orders.setdefault(stamp, order)
            names = [self.array.names[j] for j in order]
            self.inbox.append((t + LATENCY_S, stamp, names, [float(u[j]) for j in order]))

    def read(self, names: list[str], effort: list[float]) -> np.ndarray:
        if self.fault == "positional":
            return np.array(effort)
        by_name = dict(zip(names, effort, strict=True))
        u = np.array([by_name[n] for n in self.array.names])
        if self.fault == "ignore_rw2":
            u[1] = 0.0
        return u

    def advance(self, u: np.ndarray, t: float) -> None:
        stamp = self.k * self.dt_ns
        step = self.plant.step(u, stamp * 1e-9, self.rec.setup.dt_s)
        self.rec.applied.append(Sample(stamp, "body", tuple(step.body_torque_b), t))
        self.previous_effort, self.effort = self.effort, step.motor_torque_nm
        self.k += 1
        self.publish(t)

    def run(self, limit_s: float = 60.0):
        lim = self.rec.setup.limits
        n, t, last, held = 0, 0.0, np.zeros(len(self.array)), 0
        self.publish(t)
        first_sent = sent = t
        while not self.driver.done and t < limit_s:
            n += 1
            t = n * TICK_S
            due = [m for m in self.inbox if m[0] <= t]
            self.inbox = [m for m in self.inbox if m[0] > t]
            for _, stamp, names, effort in due:
                if stamp == self.k * self.dt_ns:
                    held, last = 0, self.read(names, effort)
                    self.advance(last, t)
                    first_sent = sent = t
            if t - first_sent > lim.torque_timeout_s:
                held += 1
                last = last if held <= lim.max_held_steps else np.zeros(len(self.array))
                self.advance(last, t)
                first_sent = sent = t
            elif t - sent > lim.resend_period_s:
                sent = t
                self.publish(t)
            self.send(self.driver.on_tick(t), t)
        return self.rec


def judged(scenario: Scenario, fault: str | None = None) -> dict:
    return {r.point: r for r in checker.judge(SyntheticWheelBridge(scenario, fault).run())}


# --- (1) the checker on synthetic recordings ------------------------------------------


def test_script_sends_motor_torques_some_beyond_the_limits_in_changing_orders():
    limit = load_scenario(PYRAMID).wheels.max_torque
    commands = [driver_mod.wheel_torque(i, limit) for i in range(40)]
    assert all(u.shape == (4,) for u in commands)
    assert not any(np.any(u) for u in commands[20:30])
    assert sum(np.any(np.abs(u) > limit) for u in commands) >= 8  # clipped by the wheels
    assert driver_mod.wheel_order(0, 4) == (0, 1, 2, 3)
    assert driver_mod.wheel_order(5, 4) == (1, 2, 3, 0)


def test_checker_passes_a_correct_wheel_plant():
    res = judged(load_scenario(PYRAMID))
    bad = {p: r.line() for p, r in res.items() if r.status != "PASS"}
    assert not bad, bad
    assert "hub and wheels (WheelPlant)" in res["torque_step"].detail
    wheels = res["wheels"].detail
    assert "of 4 wheels, each stamped with its state" in wheels and "0 refused" in wheels
    assert "and wheel states 'body'" in res["frames"].detail


def test_checker_passes_a_wheel_at_its_speed_limit_and_a_failed_wheel(tmp_path):
    res = judged(limited(tmp_path))
    assert res["wheels"].status == "PASS", res["wheels"].line()
    assert res["torque_step"].status == "PASS", res["torque_step"].line()
    assert "0 refused" not in res["wheels"].detail


@pytest.mark.parametrize(
    "fault, words",
    [
        ("ignore_rw2", "wheel rw2: effort 0 N m"),
        ("ignore_rw2", "the wheel applied no torque: its command ignored"),
        ("wheel_stamp", "without a wheel state of their stamp (first: state 0"),
        ("missing_wheel", "wheel(s) ['rw4'] missing from name"),
        ("rpm", "published in rpm, the contract is rad/s"),
        ("unclipped", "not clipped to max_torque_nm 0.03"),
        ("positional", "effort"),
        ("effort_late", "the step before: the effort one step late"),
    ],
)
def test_checker_fails_a_broken_wheel_plant_on_the_wheels_point(fault, words):
    res = judged(load_scenario(PYRAMID), fault)
    assert res["wheels"].status == "FAIL", res["wheels"].line()
    assert words in res["wheels"].detail, res["wheels"].detail


def test_checker_names_a_wheel_past_its_speed_limit(tmp_path):
    res = judged(limited(tmp_path), "no_speed_limit")
    assert res["wheels"].status == "FAIL"
    assert "wheel rw1" in res["wheels"].detail
    assert "at its speed limit" in res["wheels"].detail, res["wheels"].detail


def test_torque_step_names_a_command_read_by_position():
    res = judged(load_scenario(PYRAMID), "positional")
    assert res["torque_step"].status == "FAIL"
    assert "the efforts read by position, not by name" in res["torque_step"].detail
    assert "read by name, in any order" in res["torque_step"].detail


def test_a_late_effort_fails_only_the_wheels_point():
    res = judged(load_scenario(PYRAMID), "effort_late")
    assert {p for p, r in res.items() if r.status != "PASS"} == {"wheels"}


def test_a_wheel_state_whose_state_is_still_in_flight_is_not_stray():
    """The recording ends between a wheel state and its attitude (real time: separate
    topics arrive in any order); a wheel state stamped after every state received is not
    judged, one stamped between states is."""
    rec = SyntheticWheelBridge(load_scenario(PYRAMID)).run()
    rec.attitude = [a for a in rec.attitude if a.stamp_ns != rec.attitude[-1].stamp_ns]
    res = {r.point: r for r in checker.judge(rec)}
    assert res["wheels"].status == "PASS", res["wheels"].line()
    w = rec.wheel_states[3]
    rec.wheel_states.append(JointSample(w.stamp_ns + 1, *w[1:]))
    res = {r.point: r for r in checker.judge(rec)}
    assert "1 wheel state stamps that are no state's" in res["wheels"].detail


def test_wheels_point_without_wheel_states_and_skipped_without_wheels():
    rec = SyntheticWheelBridge(load_scenario(PYRAMID)).run()
    rec.wheel_states = []
    res = {r.point: r for r in checker.judge(rec)}
    assert res["wheels"].detail.startswith("no /spacecraft/wheel_states message")
    assert "the wheel plant cannot be judged" in res["torque_step"].detail
    plain = record.Recording(record.Setup.from_scenario(load_scenario(CASE1), LOCKSTEP))
    assert checker.judge(plain)[record.POINTS.index("wheels") - 2].status == "SKIP"


# --- (2) the real tool, real processes ---------------------------------------------


def run_check(env: dict, mode: str, launch: str) -> tuple[int, dict[str, str], list[str]]:
    """The tool on case1_rw_pyramid: (exit code, line per point, all stdout lines)."""
    return run_bridge_check(env, mode, launch, "--scenario", str(PYRAMID))


@pytest.mark.ros
@pytest.mark.slow
@needs_workspace
@pytest.mark.parametrize("mode", [LOCKSTEP, REALTIME])
@pytest.mark.parametrize(
    "bridge",
    ["ros2 run spacecraft_bridge_example bridge", "ros2 run spacecraft_sim rigid_body_sim"],
    ids=["example_bridge", "rigid_body_sim"],
)
def test_wheel_plants_pass_every_point(ros_env, mode, bridge):
    """The example bridge (its own RK4 on quaternions, written from docs/hil_bridge.md)
    and the project's simulator, both flying the pyramid's wheels."""
    code, by_point, lines = run_check(ros_env(), mode, bridge)
    assert list(by_point) == list(record.POINTS), lines
    skipped = {"resend"} if mode == REALTIME else set()
    for point, line in by_point.items():
        assert line.startswith("SKIP" if point in skipped else "PASS"), lines
    assert "/spacecraft/wheel_states" in by_point["qos"], lines
    assert "hub and wheels" in by_point["torque_step"], lines
    assert code == 0 and lines[-1].startswith("SUMMARY PASS"), lines


@pytest.mark.ros
@pytest.mark.slow
@needs_workspace
@pytest.mark.parametrize(
    "script, words",
    [
        ("wheel_ignores_one.py", "wheel rw2: effort 0 N m"),
        ("wheel_stamps_late.py", "without a wheel state of their stamp"),
    ],
)
def test_broken_wheel_bridge_fails_the_wheels_point(ros_env, script, words):
    launch = f"{shlex.quote(sys.executable)} {shlex.quote(str(BROKEN / script))}"
    code, by_point, lines = run_check(ros_env(), LOCKSTEP, launch)
    assert code == 1, lines
    assert by_point["wheels"].startswith("FAIL wheels: ") and words in by_point["wheels"], lines
    assert "wheels" in lines[-1].split("failed: ")[1], lines
    assert by_point["sigint"].startswith("PASS sigint"), lines
