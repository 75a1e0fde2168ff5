"""The planner node's logic without ROS: the guidance's answer to each measured state.

Inputs: each complete measured state (stamp, ns; ``sigma_BN``; ``omega_B``, rad/s) and
whether the node is active. Outputs: :meth:`PlannerStepper.step`, the target
(``sigma_RN``; ``omega_t``, target axes, rad/s), published first, then
:meth:`PlannerStepper.report`, the measured attitude's keep-out margin (deg, eq. 5),
the ``/diagnostics`` values and a status to publish; each with the (level, text)
lines to log.

* The guidance (:class:`attitude_core.fsw.guidance.guidance.Guidance`) is built from the
  first measured attitude (a restarted planner resumes from where the spacecraft is),
  with what :func:`attitude_core.assembly.guidance.prepare_guidance` made before it;
  routes planned again during the run are computed in a worker thread.
* Clock: the first state's stamp is the guidance's ``t = 0`` (the sky's time is
  ``epoch_utc`` plus the stamps' time since then).
* Inactive after its first target (a deactivated node): the last target is held at
  rest, a safe stop; nothing is stepped.
* The state watchdog (:mod:`attitude_core.fsw.fdir.state_watchdog`, the controller's
  rule): :meth:`PlannerStepper.tick` on the node's clock opens the faults of a lost
  state (their ``/diagnostics``) and, after ``fdir.safe_after_s``, reports
  ``safe_mode`` (latched: every later state gets the last target, held); a state that
  comes back ends the fault and the guidance goes on from it
  (:meth:`Guidance.resume`).
* A new acceleration derating is logged; a new status is reported once.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from attitude_core.assembly.goal_sequence import GoalSequence
from attitude_core.assembly.guidance import (
    PreparedGuidance,
    prepare_guidance,
)
from attitude_core.assembly.guidance_limits import WheelBudget
from attitude_core.config.scenario import Scenario
from attitude_core.contract.diagnostics import PlannerDiagnostics
from attitude_core.contract.faults import Fault
from attitude_core.contract.goals import GOAL_FRAME, GoalReport, goal_name
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.fdir.state_watchdog import FdirMode, StateWatchdog
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.fsw.guidance.guidance_base import Executor, GuidanceOutput
from attitude_core.models.mrp import mrp_from_quat_single
from attitude_core.runtime.planner_report import planner_diagnostics

__all__ = [
    "PlannerStep",
    "PlannerReport",
    "PlannerStepper",
    "PlannerTick",
    "goal_log",
    "GOAL_NORM_TOL",
]

Vector = npt.NDArray[np.float64]
Logs = list[tuple[str, str]]


@dataclass(frozen=True)
class PlannerStep:
    """The target of one state. ``result`` is None when the target is held (inactive):
    ``sigma_t`` is then the last target and ``omega_t`` zero."""

    stamp_ns: int
    t_s: float  # guidance time: since the first state, s
    sigma_bn: Vector
    sigma_t: Vector
    omega_t: Vector
    result: GuidanceOutput | None = None
    step_s: float = 0.0  # wall time of the guidance update, s
    logs: Logs = field(default_factory=list)
    faults: list[Fault] = field(default_factory=list)  # the faults this state ended
    goals: list[GoalReport] = field(default_factory=list)  # the goal reports it made

    @property
    def held(self) -> bool:
        return self.result is None


@dataclass(frozen=True)
class PlannerTick:
    """A tick of the node's clock: the watchdog's mode, the faults it opened, and
    ``status`` when it changed (``safe_mode``)."""

    mode: FdirMode
    faults: list[Fault]
    status: PlannerStatus | None


@dataclass(frozen=True)
class PlannerReport:
    """What follows a step's target: the margin, the diagnostics, and ``status`` when
    it changed (None: unchanged, nothing to publish)."""

    margin_deg: float
    diagnostics: PlannerDiagnostics
    status: PlannerStatus | None
    logs: Logs


GOAL_NORM_TOL = 1e-6
"""How far a goal quaternion's norm may be from 1."""


def goal_log(goal: GoalReport) -> tuple[str, str]:
    """The log line of a goal report, at its outcome's level."""
    level = {0: "info", 1: "warning"}.get(int(goal.outcome.level), "error")
    if not goal.final and not math.isnan(goal.t_reach_s):
        return level, f"goal {goal.name} arrived at {goal.t_reach_s:.3f} s"
    why = f": {goal.reason}" if goal.reason else ""
    return level, f"goal {goal.name} {goal.outcome}{why}"


_KEPT_WHEEL_STEPS = 16
"""Wheel commands and states kept to judge a step whose pieces come out of order."""


class PlannerStepper:
    """See the module docstring. ``prepared``: :func:`prepare_guidance` of ``scenario``
    (made here when not given); ``executor``: where routes are planned again (default: a
    worker thread of its own, stopped by :meth:`close`)."""

    def __init__(
        self,
        scenario: Scenario,
        prepared: PreparedGuidance | None = None,
        executor: Executor | None = None,
    ) -> None:
        self.scenario = scenario
        self.prepared = prepare_guidance(scenario) if prepared is None else prepared
        self.own_thread: ThreadPoolExecutor | None = None
        if executor is None:
            self.own_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="route")
            executor = self.own_thread
        self.executor = executor
        # The goals (the plan's, or the scenario's own, then those received), one in
        # force, each with its guidance: built at the first state.
        self.sequence = GoalSequence(scenario, self.prepared, executor)
        self.started = False
        self.first_stamp_ns = 0
        self.last_stamp_ns = 0  # the last state stepped
        self.status: PlannerStatus | None = None
        self.derating = 1.0
        self.sigma_t: Vector | None = None  # the last target
        self.watchdog = StateWatchdog(scenario.watchdog)
        self.wheels = None if scenario.wheels is None else WheelBudget(scenario)
        self.commands: dict[int, Vector] = {}  # wheel torques sent, by state stamp
        # speeds, applied torques and sigma_BN by state stamp, kept to judge
        self.wheel_states: dict[int, tuple[Vector, Vector, Vector]] = {}
        self.wheel_stamp: int | None = None  # the state the wheel budget last saw

    @property
    def guidance(self) -> Guidance | None:
        """The guidance of the goal in force (None before the first state)."""
        return self.sequence.guidance

    def takes_input(self, active: bool) -> bool:
        """Active, or deactivated after its first target: it then holds that target."""
        return active or self.guidance is not None

    def command(
        self, goal_id: int, frame: str, xyzw: tuple[float, float, float, float]
    ) -> list[GoalReport]:
        """A goal message (``<run namespace>/planner/goal``: the goal's id, its header
        stamp in ns; its frame; the body's attitude in the inertial frame, x y z w). A
        malformed one (frame, non-finite, norm off 1 by more than
        :data:`GOAL_NORM_TOL`) is refused at once, the goal in force kept: its report
        is returned. A well-formed one is judged at the next state."""
        t_s = 0.0 if not self.started else (self.last_stamp_ns - self.first_stamp_ns) / NS_PER_S
        name = goal_name(goal_id)
        norm = math.sqrt(sum(v * v for v in xyzw))
        why = ""
        if frame != GOAL_FRAME:
            why = f"frame_id {frame!r}, not {GOAL_FRAME!r} (the body's attitude in it)"
        elif not all(math.isfinite(v) for v in xyzw):
            why = f"quaternion not finite: {list(xyzw)}"
        elif abs(norm - 1.0) > GOAL_NORM_TOL:
            why = f"quaternion norm {norm:.9g}, not 1 within {GOAL_NORM_TOL:g}"
        if why:
            sigma = (
                (math.nan,) * 3
                if not math.isfinite(norm) or norm == 0.0
                else mrp_from_quat_single(*xyzw)
            )
            self.sequence.refuse(goal_id, name, sigma, t_s, why)
            return [replace(self.sequence.records[-1], origin_ns=self.first_stamp_ns)]
        self.sequence.command(goal_id, name, mrp_from_quat_single(*xyzw), t_s)
        return []

    def step(
        self,
        stamp_ns: int,
        sigma_bn: Vector,
        omega_b: Vector,
        active: bool = True,
        at_ns: int | None = None,
        wheels: tuple[Vector, Vector] | None = None,
    ) -> PlannerStep:
        """The target of the state stamped ``stamp_ns``; ``at_ns``: its time for the
        watchdog (the stack's clock; default: its stamp); held when not ``active`` or in
        safe mode. ``wheels``: the wheel state of the stamp (speeds, applied torques)."""
        at = stamp_ns if at_ns is None else at_ns
        ended = self.watchdog.measured(at, at) if active else []
        if not active or self.watchdog.safe:
            held = sigma_bn if self.sigma_t is None else self.sigma_t
            t_s = (stamp_ns - self.first_stamp_ns) / NS_PER_S
            return PlannerStep(stamp_ns, t_s, sigma_bn, held, np.zeros(3), faults=ended)
        logs: Logs = []
        t_s = (stamp_ns - self.first_stamp_ns) / NS_PER_S
        first = not self.started
        if first:
            self.started, self.first_stamp_ns, t_s = True, stamp_ns, 0.0
            logs.append(("info", f"planning from sigma_BN = {sigma_bn.round(6).tolist()}"))
        elif ended and self.guidance is not None:  # states back after a gap: go on from it
            self.guidance.resume(t_s, sigma_bn, omega_b)
            logs += [("info", f"states back: {f.detail}") for f in ended]
        before = self.guidance
        self.sequence.begin(t_s, sigma_bn, omega_b)  # the goal in force for this state
        if wheels is not None and self.wheels is not None:
            self._wheel_state(stamp_ns, sigma_bn, wheels, logs)
        t0 = time.perf_counter()
        result = self.sequence.update(t_s, sigma_bn, omega_b)
        step_s = time.perf_counter() - t0
        if self.guidance is not before:  # a goal came in force: its route
            self._route_logs(logs)
        goals = [replace(g, origin_ns=self.first_stamp_ns) for g in self.sequence.reports]
        logs += [goal_log(g) for g in goals]
        self.last_stamp_ns = stamp_ns
        self.sigma_t = np.array(result.target.sigma_t, dtype=float)
        omega_t = np.array(result.target.omega_t, dtype=float)
        return PlannerStep(
            stamp_ns, t_s, sigma_bn, self.sigma_t, omega_t, result, step_s, logs, ended, goals
        )

    def wheel_command(self, stamp_ns: int, motor_torque_nm: Vector) -> list[tuple[str, str]]:
        """The controller's motor torques for the state stamped ``stamp_ns``; when the
        next state's wheel state is already in, that step is judged now."""
        self.commands[stamp_ns] = np.asarray(motor_torque_nm, dtype=float)
        while len(self.commands) > _KEPT_WHEEL_STEPS:
            del self.commands[min(self.commands)]
        logs: Logs = []
        ahead = self.wheel_stamp is not None and self.wheel_stamp > stamp_ns
        if ahead and self.guidance is not None:
            later = [s for s in self.wheel_states if s > stamp_ns]
            if later and stamp_ns in self.wheel_states:
                self._judge(stamp_ns, min(later), logs)
        return logs

    def _wheel_state(
        self, stamp_ns: int, sigma_bn: Vector, wheels: tuple[Vector, Vector], logs: Logs
    ) -> None:
        """The wheel state of a stepped state: the step before it judged (when its
        command is in), the first one's speeds checked against the declared."""
        assert self.wheels is not None
        speeds, effort = (np.asarray(w, dtype=float) for w in wheels)
        self.wheel_states[stamp_ns] = (speeds, effort, np.asarray(sigma_bn, dtype=float))
        while len(self.wheel_states) > _KEPT_WHEEL_STEPS:
            del self.wheel_states[min(self.wheel_states)]
        previous, self.wheel_stamp = self.wheel_stamp, stamp_ns
        self._judge(previous, stamp_ns, logs)

    def _judge(self, before: int | None, at: int, logs: Logs) -> None:
        """The step from the state ``before`` (its command) to ``at`` (what was applied)."""
        assert self.wheels is not None and self.guidance is not None
        speeds, effort, sigma = self.wheel_states[at]
        if before is not None:
            if before not in self.commands or before not in self.wheel_states:
                return  # judged when the command comes
            self.wheels.commanded(self.commands.pop(before), self.wheel_states[before][0])
        usable = self.wheels.watch.usable.copy()
        limits = self.wheels.measured(sigma, speeds, effort)
        why = self.wheels.infeasible
        if limits is None and why is not None and self.guidance.reason != why:
            self.guidance.declare_infeasible(why)
            logs.append(("error", f"infeasible: {why}"))
        if limits is None:
            return
        self.guidance.limits = limits
        names = self.wheels.array.names
        now = self.wheels.watch.usable
        lost = [n for n, was, is_ in zip(names, usable, now, strict=True) if was and not is_]
        why = f"wheel(s) {lost} stopped answering" if lost else "measured wheel speeds"
        logs.append(
            (
                "warning" if lost else "info",
                f"{why}: slew re-budgeted at {limits.max_rate_rad_s:.4g} rad/s",
            )
        )

    def rebase_watchdog(self) -> None:
        """The stack's clock changed (the first ``/clock``): the watchdog starts again."""
        origin = self.first_stamp_ns if self.guidance is not None else None
        self.watchdog = StateWatchdog(self.scenario.watchdog, origin)

    def tick(self, now_ns: int) -> PlannerTick:
        """A tick of the node's clock at ``now_ns``: the faults of a stale state, and the
        ``safe_mode`` status once (latched)."""
        mode, opened = self.watchdog.check(now_ns)
        status = None
        if mode is FdirMode.SAFE_MODE and self.status is not PlannerStatus.SAFE_MODE:
            self.status = status = PlannerStatus.SAFE_MODE
        return PlannerTick(mode, opened, status)

    def report(self, step: PlannerStep, rejected: int) -> PlannerReport:
        """The report of a stepped (not held) ``step``; ``rejected``: messages refused."""
        if step.result is None:
            raise ValueError("a held target has no report of its own")
        margin = self.scenario.sky.min_margin_deg_single(step.t_s, step.sigma_bn)
        diag = planner_diagnostics(self.guidance, step.result, step.step_s, margin, rejected)
        logs: Logs = []
        at = f"at stamp {step.stamp_ns / NS_PER_S:.3f} s"
        derating = step.result.derating
        if derating != self.derating:
            self.derating = derating
            logs.append(
                (
                    "warning",
                    "the body fell behind a profile within the declared actuator limits: "
                    "the plant is weaker than the scenario says; profile acceleration now "
                    f"{derating:g} of the declared {at}",
                )
            )
        status = step.result.target.status
        changed = None if status == self.status else status
        if changed is not None:
            self.status = changed
            logs.append(("info", f"status {changed} {at}"))
        return PlannerReport(margin, diag, changed, logs)

    def _route_logs(self, logs: Logs) -> None:
        """The route of the guidance that just came in force (or why there is none)."""
        guidance = self.guidance
        route = None if guidance is None else guidance.route
        if route is not None and route.feasible:
            logs.append(
                (
                    "info",
                    f"global route: {route.legs} leg(s), "
                    f"{np.degrees(route.rotation_rad):.1f} deg of rotation, "
                    f"clearance {route.clearance_deg:.2f} deg",
                )
            )
        elif route is not None:
            logs.append(("error", f"infeasible: {route.reason}"))

    def close(self) -> None:
        """Stop its own route thread (a route in progress is dropped)."""
        if self.own_thread is not None:
            self.own_thread.shutdown(wait=False, cancel_futures=True)
