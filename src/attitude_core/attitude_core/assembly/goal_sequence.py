"""Commanded goals: a plan's targets and goals received at run time, one in force.

Inputs: a :class:`~attitude_core.config.scenario.Scenario` (its ``plan.*``), each
measured state ``(t, sigma_BN, omega_B)`` (:meth:`GoalSequence.update`) and the goals
commanded meanwhile (:meth:`GoalSequence.command`, ``sigma_DN``). Outputs: the target of
each state (the guidance of the goal in force), the status to report, and each goal's
record (:class:`~attitude_core.contract.goals.GoalReport`), reported when it is taken
and when it ends (:attr:`GoalSequence.reports`).

* A goal is judged at the first state after it came (:func:`goal_clearance`): one whose
  attitude puts an instrument inside a keep-out, or an axis outside a keep-in cone, now,
  or, on a moving sky, that the sky leaves no clear stretch of its dwell between its
  expected arrival and the run's end, is **refused** before any torque, with the
  reason; so is one no route reaches (enclosed). A coverage the body can wait out is
  flown (``blocked`` meanwhile). The guidance's buffer is capped by the goal's least
  margin until the end of its dwell
  (:func:`~attitude_core.assembly.guidance.buffer_deg`). The goal in force stays; the status
  ``refused`` is reported for that state.
* Otherwise it preempts the goal in force (``preempted``, or ``reached`` if the body had
  arrived) and a new guidance is planned from the measured state, rate included (the
  profile starts from the body's rate), with every guarantee of a single slew: the same
  :func:`~attitude_core.assembly.guidance.guidance_from_scenario`.
* A plan's targets are flown in order: each is ``reached`` once the body has stayed
  ``arrived`` for its dwell (the dwell restarts if the arrival is withdrawn); a target
  refused, infeasible or stuck is recorded and skipped. After the last one the status
  is ``complete`` and the last goal stays in force. A goal received during a plan goes
  first; the plan's targets left follow it once it is reached (a received goal's dwell
  is unbounded: it holds until the next goal).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace

import numpy as np

from attitude_core.assembly.guidance import (
    PreparedGuidance,
    buffer_deg,
    guidance_from_scenario,
    scenario_eta_s,
)
from attitude_core.config.scenario import Scenario
from attitude_core.contract.goals import (
    SOURCE_PLAN,
    SOURCE_SCENARIO,
    SOURCE_TOPIC,
    GoalReport,
)
from attitude_core.contract.status import GoalOutcome, PlannerStatus
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.fsw.guidance.guidance_base import Executor, GuidanceOutput
from attitude_core.fsw.guidance.route import RoutePlanner
from attitude_core.models.mrp import Vec3Like, angle_between_single, to_principal

__all__ = ["GoalSequence", "goal_clearance", "CLEARANCE_STEP_S"]

CLEARANCE_STEP_S = 1.0
"""Sampling of a moving sky over a goal's dwell when it is judged, s."""


def goal_clearance(
    scenario: Scenario, t_s: float, sigma_goal: Vec3Like, dwell_s: float, eta_s: float = 0.0
) -> str:
    """Why the attitude ``sigma_goal`` cannot be held (an instrument inside a keep-out or
    an axis outside a keep-in, eq. 5), or "" if it can.

    Refused when it is inside now. On a moving sky, a goal with a bounded dwell is also
    refused when the sky leaves it no clear stretch of its dwell between its expected
    arrival, ``t_s + eta_s``, and the run's end (sampled every
    :data:`CLEARANCE_STEP_S`; a dwell longer than what is left of the run asks for the
    rest of the run). A coverage the body can wait out is no reason: the guidance holds
    the body clear of it (``blocked``) and flies the goal after, as a single slew's. A
    goal held until the next (unbounded dwell) is judged now only."""
    sky = scenario.sky
    names = scenario.constraint_names
    margins = sky.constraint_margins_deg(float(t_s), np.asarray(sigma_goal, dtype=float))
    c = int(np.argmin(margins))
    if margins[c] <= 0.0:
        what = (
            f"outside keep-in cone {names[c]}"
            if names[c].startswith("keep_in/")
            else f"inside the keep-out of {names[c]}"
        )
        return f"the goal attitude is {what} (margin {margins[c]:.2f} deg)"
    end = min(scenario.sim_time_s, sky.horizon_s) if not sky.static else t_s
    arrive = min(t_s + eta_s, end)
    if sky.static or not math.isfinite(dwell_s) or end <= t_s:
        return ""
    need = min(dwell_s, end - arrive)
    times = np.append(np.arange(arrive, end, CLEARANCE_STEP_S), end)
    goal = np.broadcast_to(np.asarray(sigma_goal, dtype=float), (len(times), 3))
    ahead = sky.constraint_margins_deg(times, goal)
    clear = ahead.min(axis=1) > 0.0
    run_from: float | None = None
    for t, ok in zip(times, clear, strict=True):
        if not ok:
            run_from = None
        elif run_from is None:
            run_from = float(t)
        if run_from is not None and t - run_from >= need:
            return ""
    first = int(np.argmax(~clear))
    c = int(np.argmin(ahead[first]))
    return (
        f"the sky leaves the goal no clear {dwell_s:.1f} s after its expected arrival at "
        f"{arrive:.1f} s before the run's end: {names[c]} covers it at t = "
        f"{times[first]:.1f} s (margin {ahead[first, c]:.2f} deg)"
    )


class GoalSequence:
    """See the module docstring. ``prepared``: what the scenario's first goal was
    prepared with (:func:`~attitude_core.assembly.guidance.prepare_guidance`);
    ``executor``: where routes are planned again."""

    def __init__(
        self,
        scenario: Scenario,
        prepared: PreparedGuidance | None = None,
        executor: Executor | None = None,
    ) -> None:
        self.scenario = scenario
        self.prepared = prepared
        self.executor = executor
        self.guidance: Guidance | None = None
        self.records: list[GoalReport] = []  # every goal, in the order it came
        self.reports: list[GoalReport] = []  # the reports of the last update
        self.queue: deque[int] = deque()  # the plan's targets left (indices into records)
        self.incoming: deque[int] = deque()  # goals received since the last state
        self._current: int | None = None  # the goal in force (index), until it ends
        self._refused: list[GoalReport] = []  # refused on receipt, reported next state
        self._refused_now = False  # one refused at the state begun
        self._begun: float | None = None  # the state time begun, until its update
        self._arrived_at: float | None = None
        self._routes: dict[float, RoutePlanner] = {}
        if prepared is not None:
            self._routes[prepared.routes.buffer_deg] = prepared.routes
        for k, target in enumerate(scenario.plan):
            self._add(SOURCE_PLAN, k, target.name, target.desired_mrp, target.dwell_s, 0.0)
        if not scenario.plan:  # the scenario's own goal: in force first, not reported
            self._add(SOURCE_SCENARIO, 0, "desired_mrp", scenario.desired_mrp, math.inf, 0.0)
        self._plan = bool(scenario.plan)

    @property
    def current(self) -> GoalReport | None:
        """The goal in force (None: none, or the last one ended)."""
        return None if self._current is None else self.records[self._current]

    @property
    def complete(self) -> bool:
        """Every target of the plan is done and no goal is in force or waiting."""
        return self._plan and self._current is None and not self.queue and not self.incoming

    @property
    def goal(self) -> np.ndarray:
        assert self.guidance is not None
        return self.guidance.goal

    @property
    def reason(self) -> str:
        return "" if self.guidance is None else self.guidance.reason

    @property
    def route_rotation_deg(self) -> float:
        return math.nan if self.guidance is None else self.guidance.route_rotation_deg

    @property
    def reported(self) -> list[GoalReport]:
        """The goals of ``summary.json`` ``goals``: the plan's and those received."""
        return [r for r in self.records if r.source != SOURCE_SCENARIO]

    def refuse(self, goal_id: int, name: str, sigma_goal: Vec3Like, t_s: float, why: str) -> None:
        """A goal refused on receipt (a malformed message), at state time ``t_s``: on
        record, reported at the next state; the goal in force stays."""
        s = np.asarray(sigma_goal, dtype=float)
        goal = (float(s[0]), float(s[1]), float(s[2]))
        rec = GoalReport(SOURCE_TOPIC, goal_id, name, goal, math.inf, GoalOutcome.REFUSED, t_s)
        self.records.append(rec.ended(GoalOutcome.REFUSED, t_s, why))
        self._refused.append(self.records[-1])

    def command(self, goal_id: int, name: str, sigma_goal: Vec3Like, t_s: float) -> None:
        """A goal received at state time ``t_s`` (judged at the next state), held until
        the next goal."""
        self._add(SOURCE_TOPIC, goal_id, name, sigma_goal, math.inf, t_s, received=True)

    def _add(
        self,
        source: str,
        goal_id: int,
        name: str,
        sigma: Vec3Like,
        dwell_s: float,
        t_s: float,
        received: bool = False,
    ) -> None:
        s = to_principal(np.asarray(sigma, dtype=float))
        goal = (float(s[0]), float(s[1]), float(s[2]))
        rec = GoalReport(source, goal_id, name, goal, dwell_s, GoalOutcome.ACCEPTED, t_s)
        self.records.append(rec)
        (self.incoming if received else self.queue).append(len(self.records) - 1)

    def _set(self, k: int, rec: GoalReport, report: bool = True) -> None:
        """Record ``rec`` as goal ``k`` (it leaves force when final); ``report``: one of
        this state's :attr:`reports`."""
        self.records[k] = rec
        if k == self._current and rec.final:
            self._current = None
        if report and rec.source != SOURCE_SCENARIO:
            self.reports.append(rec)

    def update(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> GuidanceOutput:
        """The target for the measured state at ``t_s``; :attr:`reports` are the goal
        reports this state made."""
        if self._begun != t_s:
            self.begin(t_s, sigma_bn, omega_b)
        self._begun = None
        refused = self._refused_now
        assert self.guidance is not None
        out = self.guidance.update(t_s, sigma_bn, omega_b)
        self._follow(t_s)
        if refused:
            out.target.status = PlannerStatus.REFUSED
        elif self.complete:
            out.target.status = PlannerStatus.COMPLETE
        return out

    def begin(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> None:
        """The goals judged for the state at ``t_s``, before :meth:`update` of that state
        (which calls it when not called): the guidance in force is then this state's
        (e.g. for the wheel budget to see it first)."""
        self.reports, self._refused = self._refused, []
        on_receipt = bool(self.reports)  # refused when they came: reported now
        self._refused_now = self._take(t_s, sigma_bn, omega_b) or on_receipt
        self._begun = t_s

    def hold_band(self) -> tuple[float, float] | None:
        """The guidance's hold band once nothing is left to fly but the goal in force,
        held until the next (the offline loop's held steps); None otherwise."""
        if self.guidance is None or self.incoming or self.queue:
            return None
        cur = self.current
        if cur is not None and math.isfinite(cur.dwell_s):
            return None
        return self.guidance.hold_band()

    def held_to(self, t_s: float) -> None:
        assert self.guidance is not None
        self.guidance.held_to(t_s)

    def finish(self, t_s: float) -> list[GoalReport]:
        """The run ended at ``t_s``: the goal in force and those waiting get their
        outcome (``reached`` if the body is on it for its dwell, or with no dwell
        bound; else ``blocked`` or ``not_reached``)."""
        self.reports = []
        if self._current is not None:
            self._end_current(t_s, GoalOutcome.NOT_REACHED)
        while self.incoming or self.queue:
            k = (self.incoming or self.queue).popleft()
            left = self.records[k].ended(GoalOutcome.NOT_REACHED, t_s, "the run ended first")
            self._set(k, left)
        return self.reports

    def _take(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> bool:
        """Judge the goals received since the last state (each preempts, or is refused),
        then, with none in force, the plan's next targets until one is; True if one was
        refused at this state."""
        refused = False
        while self.incoming or (self._current is None and self.queue):
            k = (self.incoming or self.queue).popleft()
            rec = self.records[k]
            rotation = math.degrees(angle_between_single(sigma_bn, rec.sigma_goal))
            rec = replace(rec, t_start_s=t_s, rotation_deg=rotation)
            if rec.source == SOURCE_PLAN:  # a plan's target is commanded when its turn comes
                rec = replace(rec, t_commanded_s=t_s)
            eta = 0.0  # the expected slew to this goal (a moving sky only)
            if not self.scenario.sky.static:
                eta = scenario_eta_s(self.scenario.retargeted(np.asarray(rec.sigma_goal)), sigma_bn)
            why = goal_clearance(self.scenario, t_s, rec.sigma_goal, rec.dwell_s, eta)
            guidance = None if why else self._guidance(rec, t_s, sigma_bn, omega_b, eta)
            if guidance is not None and guidance.status is PlannerStatus.INFEASIBLE:
                why = guidance.reason
                if rec.source == SOURCE_TOPIC:  # a received goal no route reaches: refused
                    why = f"no route reaches it: {why}"
            if why:
                planned = rec.source != SOURCE_TOPIC and guidance is not None
                outcome = GoalOutcome.INFEASIBLE if planned else GoalOutcome.REFUSED
                refused |= outcome is GoalOutcome.REFUSED
                self._set(k, replace(rec, t_start_s=math.nan).ended(outcome, t_s, why))
                if self.guidance is None and not self.queue and not self.incoming:
                    # nothing was ever in force: the target holds the start
                    hold = guidance or self._guidance(rec, t_s, sigma_bn, omega_b, eta)
                    hold.declare_infeasible(why)
                    self.guidance = hold
                continue
            if self._current is not None:
                self._end_current(t_s, GoalOutcome.PREEMPTED)
            if rec.source == SOURCE_TOPIC:  # the scenario's own goal, not yet flown: dropped
                for j in [j for j in self.queue if self.records[j].source == SOURCE_SCENARIO]:
                    self.queue.remove(j)
                    self._set(j, self.records[j].ended(GoalOutcome.PREEMPTED, t_s))
            assert guidance is not None
            self.guidance = guidance
            self._arrived_at = None
            self._current = k
            self._set(k, rec)
        return refused

    def _end_current(self, t_s: float, otherwise: GoalOutcome) -> None:
        """The goal in force ends at ``t_s`` (a new goal takes over, or the run ends):
        ``reached`` if the body is on it and its dwell is over (or unbounded), else
        ``blocked`` if the sky covers it, else ``otherwise``."""
        cur, k = self.current, self._current
        assert cur is not None and k is not None
        dwell, since = self._dwell(cur), self._arrived_at
        if since is not None and (math.isinf(dwell) or t_s - since >= dwell - 1e-9):
            outcome = GoalOutcome.REACHED
        elif self.guidance is not None and self.guidance.status is PlannerStatus.BLOCKED:
            outcome = GoalOutcome.BLOCKED
        else:
            outcome = otherwise
        self._set(k, cur.ended(outcome, t_s))

    def _dwell(self, rec: GoalReport) -> float:
        """How long ``rec`` is held once arrived, s: its dwell; a received goal's (and
        the scenario's own) is unbounded, held until the next goal, but none while plan
        targets wait behind it."""
        if math.isfinite(rec.dwell_s):
            return rec.dwell_s
        return 0.0 if self.queue else math.inf

    def _follow(self, t_s: float) -> None:
        """After the guidance's update: arrival, dwell, and a target given up."""
        cur, k, g = self.current, self._current, self.guidance
        if cur is None or k is None or g is None:
            return
        if g.status is PlannerStatus.ARRIVED:
            if self._arrived_at is None:
                self._arrived_at = t_s
            if math.isnan(cur.t_reach_s):  # reported: a bag's goal then knows its arrival
                cur = replace(cur, t_reach_s=t_s)
                self._set(k, cur)
            if t_s - self._arrived_at >= self._dwell(cur) - 1e-9:
                self._set(k, cur.ended(GoalOutcome.REACHED, t_s))
        else:
            self._arrived_at = None
            if g.status is PlannerStatus.INFEASIBLE:
                self._set(k, cur.ended(GoalOutcome.INFEASIBLE, t_s, g.reason))
            elif g.status is PlannerStatus.STUCK and self.queue:
                self._set(k, cur.ended(GoalOutcome.NOT_REACHED, t_s, "stuck"))

    def _guidance(
        self, rec: GoalReport, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like, eta_s: float
    ) -> Guidance:
        """The guidance of ``rec`` from the measured state (the profile from the body's
        rate): with what was prepared for the scenario's first goal, when it is that.
        ``eta_s``: the expected slew to it (a moving sky: its dwell's hold ends then)."""
        scenario = self.scenario.retargeted(np.asarray(rec.sigma_goal))
        hold_until = None  # held until the next goal: the run's end
        if not scenario.sky.static and math.isfinite(rec.dwell_s):
            hold_until = t_s + eta_s + rec.dwell_s
        first = (  # prepared with the goal held to the run's end (buffer_deg)
            self.prepared is not None
            and hold_until is None
            and self.guidance is None
            and np.array_equal(rec.sigma_goal, self.scenario.desired_mrp)
        )
        guidance = guidance_from_scenario(
            scenario,
            sigma_0=sigma_bn,
            executor=self.executor,
            prepared=self.prepared if first else None,
            routes=None
            if first
            else self._routes.get(buffer_deg(scenario, sigma_bn, t_s, hold_until)),
            t0_s=t_s,
            hold_until_s=hold_until,
        )
        if self.guidance is not None and np.any(np.asarray(omega_b, dtype=float) != 0.0):
            guidance.omega_prev = np.array(omega_b, dtype=float)  # a goal that takes over
        if guidance.routes is not None:
            self._routes.setdefault(guidance.routes.buffer_deg, guidance.routes)
        return guidance
