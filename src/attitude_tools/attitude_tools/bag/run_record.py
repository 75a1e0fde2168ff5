"""A run rebuilt from its recording alone: bag directory -> ``RunResult``.

Step ``k`` of the run is a state stamp for which the bag holds the attitude, the body
rate and the torque applied over the step, all with that stamp. The torque is the
simulator's ``applied_torque``; only a bag with none at all (a plant that does not
publish it) falls back to the commanded torque. Commanded torques are never mixed in
where applied ones are missing: anyone can publish a torque with a step's stamp (a stray
node, a flood), only what the plant applied tells what the body got. Re-sent messages
(same topic, same stamp) count once. Steps are taken in stamp order up to the first
incomplete one, so the result is the same as the offline runner's ``RunResult`` for
the recorded span. A step without a planner target (the planner was down) has NaN
target rows. ``t`` is relative to the first stamp. States before the first complete
step, or more than 5 s after the last, are off the run's timeline (a stray publisher's
stamps, which the recorder keeps as evidence) and are not steps. Only the planner's
own ``/diagnostics`` (status name ``fepf_planner``) give step data; the nodes' run
identities there do not.

A run with sensors is rebuilt from the truth: when the bag holds
``/spacecraft/truth/*``, those are the steps' state (what safety and arrival are judged
on), and ``/spacecraft/attitude`` and ``/spacecraft/angular_velocity`` (what the loop
was fed) become :attr:`RunResult.estimate`, with the estimator's 3-sigma from its
``/diagnostics`` (status ``mekf_estimator``); the NEES needs the true bias, which the
bag does not hold (NaN). A run behind a rehearsal link (``link.*``, no sensors) is
rebuilt from the truth the same way, with no estimate: the states the link delivered
are what the loop was fed.

With a wheel array (``wheels.*``) :attr:`RunResult.wheels` comes from
``/spacecraft/wheel_states`` (each step's speeds; the torques applied over step ``k``
are the efforts of the state that ends it, none on record for the last step: NaN) and
``/controller/wheel_torque`` (the commanded, NaN where none is on record), by wheel
name. The external torque is the scenario's model (``disturbances.*``) on the recorded
attitude, held over each step as the simulator holds it.

``RunResult.faults`` is the state watchdog replayed on the stamps of the states the
loop was fed (:func:`attitude_core.fsw.fdir.state_watchdog.faults_from_stamps`), up to the
last step, and with sensors the star tracker's gaps
(:func:`attitude_core.fsw.fdir.tracker_watch.tracker_outages`): what the record shows,
whatever the nodes logged.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.contract.diagnostics import (
    ATTITUDE_3SIGMA_DEG,
    ESTIMATOR_STATUS_NAME,
    STATUS_NAME,
    PlannerDiagnostics,
)
from attitude_core.contract.goals import GOAL_DIAGNOSTIC_NAME, GoalReport
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import (
    ANGULAR_VELOCITY,
    APPLIED_TORQUE,
    ATTITUDE,
    DIAGNOSTICS,
    STAR_TRACKER,
    TARGET_MRP,
    TARGET_RATE,
    TORQUE,
    TRUTH_ANGULAR_VELOCITY,
    TRUTH_ATTITUDE,
    WHEEL_STATES,
    WHEEL_TORQUE,
    stamp_ns,
)
from attitude_core.fsw.fdir.state_watchdog import faults_from_stamps
from attitude_core.fsw.fdir.tracker_watch import tracker_outages
from attitude_core.models.mrp import mrp_from_quat
from attitude_core.record.summary import summarize
from attitude_core.record.trajectory import Estimates, RunResult, WheelRecord
from attitude_tools.bag.reader import read_attachment, read_bag

_TOPICS = (
    ATTITUDE,
    ANGULAR_VELOCITY,
    TARGET_MRP,
    TARGET_RATE,
    TORQUE,
    APPLIED_TORQUE,
    DIAGNOSTICS,
    TRUTH_ATTITUDE,
    TRUTH_ANGULAR_VELOCITY,
    STAR_TRACKER,
    WHEEL_STATES,
    WHEEL_TORQUE,
)


@dataclass
class BagRun:
    run: RunResult
    stamps_ns: npt.NDArray[np.int64]  # state stamp of each step
    receive_wall_ns: npt.NDArray[np.int64]  # recorder receive time of each step's attitude
    incomplete_steps: int  # state stamps after the last complete step


TRAILING_STATES_NS = 5 * 10**9
"""States this long after the last complete step are the run's unanswered tail; later
ones, and any before the first complete step, are not on the run's timeline."""


def _xyz(v: Any) -> tuple[float, float, float]:
    return (v.x, v.y, v.z)


def _quat(m: Any) -> tuple[float, float, float, float]:
    q = m.quaternion
    return (q.x, q.y, q.z, q.w)


def scenario_from_bag(bag_dir: str) -> Scenario:
    """The scenario stored in the bag (attachment ``scenario.yaml``)."""
    text = read_attachment(bag_dir, "scenario.yaml").decode("utf-8")
    return loads_scenario(text, f"{bag_dir}: attachment scenario.yaml")


def run_from_bag(
    bag_dir: str, scenario: Scenario | None = None, wall_time_s: float = float("nan")
) -> BagRun:
    """Rebuild the sampled trajectory of a recorded run (see module docstring)."""
    if scenario is None:
        scenario = scenario_from_bag(bag_dir)
    by_topic: dict[str, dict[int, Any]] = {t: {} for t in _TOPICS}  # deserialized messages
    three_sigma: dict[int, float] = {}  # the estimator's, by stamp
    walls: dict[str, dict[int, int]] = {ATTITUDE: {}, TRUTH_ATTITUDE: {}}  # first receipt
    goals: dict[tuple[str, int, str, float], GoalReport] = {}  # in order of first report
    for m in read_bag(bag_dir, list(by_topic)):
        stamp = stamp_ns(m.msg.header.stamp)
        if m.topic == DIAGNOSTICS:
            for st in m.msg.status:
                if st.name == GOAL_DIAGNOSTIC_NAME:  # a goal's report: its last is its record
                    goal = GoalReport.from_values({kv.key: kv.value for kv in st.values})
                    goals[(goal.source, goal.goal_id, goal.name, goal.t_commanded_s)] = goal
                if st.name == ESTIMATOR_STATUS_NAME:
                    values = {kv.key: kv.value for kv in st.values}
                    three_sigma[stamp] = float(values.get(ATTITUDE_3SIGMA_DEG, "nan"))
            if not any(st.name == STATUS_NAME for st in m.msg.status):
                continue  # another node's diagnostics (a run identity): no step data
        by_topic[m.topic][stamp] = m.msg
        if m.topic in walls:
            walls[m.topic].setdefault(stamp, m.publish_time_ns)
    sensing = bool(by_topic[TRUTH_ATTITUDE])
    att_topic, rate_topic = (
        (TRUTH_ATTITUDE, TRUTH_ANGULAR_VELOCITY) if sensing else (ATTITUDE, ANGULAR_VELOCITY)
    )
    estimated = {ATTITUDE: by_topic[ATTITUDE], ANGULAR_VELOCITY: by_topic[ANGULAR_VELOCITY]}
    by_topic[ATTITUDE], by_topic[ANGULAR_VELOCITY] = by_topic[att_topic], by_topic[rate_topic]
    wall = walls[att_topic]
    states = sorted(by_topic[ATTITUDE])
    applied = by_topic[APPLIED_TORQUE]
    source = applied if applied else by_topic[TORQUE]
    torque: dict[int, Any] = {s: source.get(s) for s in states}
    complete = [s for s in states if s in by_topic[ANGULAR_VELOCITY] and torque[s] is not None]
    if complete:  # states off the run's timeline (stray stamps, kept as evidence) are no steps
        states = [s for s in states if complete[0] <= s <= complete[-1] + TRAILING_STATES_NS]
    n = 0
    while (
        n < len(states)
        and states[n] in by_topic[ANGULAR_VELOCITY]
        and torque[states[n]] is not None
    ):
        n += 1
    if n == 0:
        raise ValueError(f"{bag_dir}: no complete step (state and torque of one stamp)")
    stamps = np.array(states[:n], dtype=np.int64)
    nan3 = (np.nan, np.nan, np.nan)

    def rows(topic: str, get: Callable[[Any], Sequence[float]]) -> npt.NDArray[np.float64]:
        found = by_topic[topic]
        return np.array([get(found[s]) if s in found else nan3 for s in states[:n]], dtype=float)

    quat = rows(
        ATTITUDE, lambda m: (m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w)
    )
    status = np.full(n, PlannerStatus.TRACKING.code, dtype=np.int8)
    d_obs = np.full(n, np.nan)
    step_s = np.full(n, np.nan)
    reason, route_deg = "", float("nan")
    for k, s in enumerate(states[:n]):
        diag = by_topic[DIAGNOSTICS].get(s)
        if diag is None or not diag.status:
            continue
        try:
            planner = PlannerDiagnostics.from_values(
                {kv.key: kv.value for kv in diag.status[0].values}
            )
        except ValueError:  # not the planner's diagnostics: the step keeps no planner data
            continue
        status[k] = planner.status.code
        d_obs[k] = planner.obstacle_distance_mrp
        step_s[k] = planner.step_time_s
        reason = planner.reason or reason
        if np.isnan(route_deg):
            route_deg = planner.route_rotation_deg
    run = RunResult(
        scenario=scenario,
        t=(stamps - stamps[0]) * 1e-9,
        sigma_bn=mrp_from_quat(quat),
        omega_b=rows(ANGULAR_VELOCITY, lambda m: _xyz(m.vector)),
        torque_b=np.array([_xyz(torque[s].wrench.torque) for s in states[:n]], dtype=float),
        sigma_t=rows(TARGET_MRP, lambda m: _xyz(m.vector)),
        omega_t=rows(TARGET_RATE, lambda m: _xyz(m.vector)),
        obstacle_distance_mrp=d_obs,
        planner_status=status,
        planner_step_s=step_s,
        wall_time_s=wall_time_s,
        planner_reason=reason,
        route_rotation_deg=route_deg,
        goals=[g.rebased(int(stamps[0])) for g in goals.values()],  # on the bag's clock
    )
    fed = sorted(estimated[ATTITUDE]) if sensing else list(states[:n])
    run.faults = faults_from_stamps(
        scenario.watchdog,
        [s for s in fed if stamps[0] <= s <= stamps[-1]],
        int(stamps[-1]),
        int(stamps[0]),
    )
    if scenario.sensors is not None and by_topic[STAR_TRACKER]:
        fixes = [(s - int(stamps[0])) * 1e-9 for s in sorted(by_topic[STAR_TRACKER])]
        end = (int(stamps[-1]) - int(stamps[0])) * 1e-9
        tracker = tracker_outages(fixes, scenario.sensors.star_tracker_rate_hz, end)
        run.faults = sorted(run.faults + tracker, key=lambda f: f.t_start_s)
    if sensing and scenario.sensors is not None:
        est_quat = np.array(
            [
                _quat(estimated[ATTITUDE][s]) if s in estimated[ATTITUDE] else (np.nan,) * 4
                for s in states[:n]
            ],
            dtype=float,
        )
        run.estimate = Estimates(
            sigma_bn=mrp_from_quat(est_quat),
            omega_b=np.array(
                [
                    _xyz(estimated[ANGULAR_VELOCITY][s].vector)
                    if s in estimated[ANGULAR_VELOCITY]
                    else nan3
                    for s in states[:n]
                ],
                dtype=float,
            ),
            attitude_3sigma_deg=np.array([three_sigma.get(s, np.nan) for s in states[:n]]),
            nees=np.full(n, np.nan),
        )
    if scenario.wheels is not None and by_topic[WHEEL_STATES]:
        run.wheels = _wheel_record(scenario, by_topic, states[:n], run)
    return BagRun(
        run, stamps, np.array([wall[s] for s in states[:n]], dtype=np.int64), len(states) - n
    )


def _by_name(msg: Any, field: str, names: Sequence[str]) -> list[float]:
    """``msg.<field>`` in the scenario's wheel order (NaN for a wheel not in it)."""
    got = dict(zip(msg.name, getattr(msg, field), strict=False))
    return [float(got.get(name, np.nan)) for name in names]


def _wheel_record(
    scenario: Scenario, by_topic: dict[str, dict[int, Any]], steps: Sequence[int], run: RunResult
) -> WheelRecord:
    """The wheels of each step (see the module docstring)."""
    assert scenario.wheels is not None
    names, m = scenario.wheels.names, len(scenario.wheels)
    states, commands = by_topic[WHEEL_STATES], by_topic[WHEEL_TORQUE]
    nan = [np.nan] * m

    def rows(found: dict[int, Any], field: str, at: Sequence[int | None]) -> np.ndarray:
        return np.array(
            [_by_name(found[s], field, names) if s in found else nan for s in at], dtype=float
        )

    following: list[int | None] = [*steps[1:], None]
    external = np.zeros((len(steps), 3))
    if scenario.disturbances is not None:
        for k, (t_s, sigma) in enumerate(zip(run.t, run.sigma_bn, strict=True)):
            external[k] = scenario.disturbances.torque_b(float(t_s), sigma)
    return WheelRecord(
        speed_rad_s=rows(states, "velocity", steps),
        commanded_nm=rows(commands, "effort", steps),
        applied_nm=rows(states, "effort", following),
        external_b=external,
    )


def summarize_bag(bag_run: BagRun) -> dict[str, Any]:
    """``attitude_core.record.trajectory.summarize`` of the recorded run, plus the recording's own
    figures: ``steps_recorded`` and ``steps_per_s``, the stepping rate from the recorder's
    receive times of the states, from the first state after the loop's first answer (the
    wait for that answer is the start-up's, as a peer still matching can make it: the
    bare rclpy ring of ``bench/ros_ring.py`` does not count its start either)."""
    summary = summarize(bag_run.run).to_json()
    wall = bag_run.receive_wall_ns
    first = 1 if len(wall) > 2 else 0
    span_s = (int(wall[-1]) - int(wall[first])) * 1e-9
    steps = len(bag_run.stamps_ns)
    summary["steps_recorded"] = steps
    summary["steps_per_s"] = (steps - 1 - first) / span_s if span_s > 0 else None
    return summary
