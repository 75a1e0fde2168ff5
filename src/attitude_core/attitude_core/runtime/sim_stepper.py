"""The simulator's stepping logic without ROS: start-up gate, lockstep handshake, real time.

:class:`SimStepper` owns the rigid body (eqs. 3-4, RK4, shadow set) and decides, given
the current wall time (``now``, monotonic seconds) and each input, what the simulator
node must do; the node only converts messages and publishes what it is told.

* Start-up: :meth:`poll_graph` with whether the graph is connected. The first step is
  taken once it has stayed connected for :data:`SETTLE_S` (every endpoint has matched);
  the run fails after ``startup_timeout_s`` without.
* Lockstep (stamps are simulated time ``k dt``): the state of step ``k`` is published and
  the body advances only on the torque stamped ``k`` (:meth:`on_torque`). :meth:`on_timer`
  re-sends the state every ``resend_period_s`` while it is missing; after
  ``torque_timeout_s`` the last torque is held for the step, at most ``max_held_steps``
  steps in a row, then the torque is stale and zero torque is applied until a
  controller answers again. Until the loop has answered once, the first state waits up
  to ``startup_timeout_s`` instead: the simulator's view of the graph does not tell
  whether the planner and the controller have matched each other yet, and under load
  that can take longer than a step's deadline (the state is re-sent meanwhile, every
  :data:`STARTUP_RESEND_FRACTION` of ``resend_period_s``: a re-send is answered
  identically, and a first state one node missed is asked for again sooner).
* Real time (stamps are the node's clock): :meth:`on_timer` is called every ``dt_s`` and
  steps with the latest torque held; a torque older than ``torque_stale_s`` (wall time
  since it arrived) is stale: zero torque. A torque stamped before the one applied is
  refused.

Behind a rehearsal link (``link.*``, :class:`attitude_core.world.link.StateLink`) the
simulator publishes the true state of every step on ``/spacecraft/truth/*`` and gives the
loop only what the link delivers (the newest state due, or none). In lockstep, at step
``k``: a delivered state (stamp ``s``) is published and the body advances on the torque
stamped ``s``, ``/clock`` ``k dt`` following that answer; without one, ``/clock`` ``k dt``
is published and, once the newest delivered state is older than
``fdir.state_timeout_s`` (the flight software's watchdog rule,
:class:`attitude_core.fsw.fdir.fdir_config.FdirConfig`), the body advances on the torque
stamped ``k dt`` (the stack's answer to that tick), else at once with the last torque
held (:attr:`Decision.more`: step again), as a plant behind a bench link does. The
answer a step waits for is therefore known in advance and the run is deterministic for
``link.seed``. In real time the link is applied to the stamps on the node's clock.

In both modes a torque is judged by the step it answers: its stamp must be one of the
last :data:`ANSWERABLE_STATES` states this simulator published, so a torque stamped
ahead (a stray message, a day in the future) is refused and counted and can never make
the real answers look old (in real time, a stamp within the span of those states, or
at most one step after the last: a watchdog's answer to a tick of its clock). Torques
that are non-finite or beyond the plausible bound
(:func:`attitude_core.runtime.plausibility.torque_bound_nm`: ``actuators.max_torque_nm`` when
set) are refused, never integrated; should the state still become non-finite, the
simulator stops (exit 1) rather than publish it. The run ends (exit code 0) after
``n_steps`` steps.

With a wheel array (``wheels.*``) the body is :class:`WheeledBody`: the command is the
motor torques of the wheels in the scenario's order (the node reads them from
``/controller/wheel_torque`` by name), the wheels apply their own limits
(:class:`attitude_core.world.wheel_plant.WheelPlant`), the applied torque published is
the body torque they made, and each state carries the wheel speeds and the motor
torques applied over the step that ended at it (``/spacecraft/wheel_states``).
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_core.contract.topics import BODY_FRAME, NS_PER_S
from attitude_core.fsw.fdir.fdir_config import FdirConfig
from attitude_core.models.link_spec import LinkSpec
from attitude_core.runtime.plausibility import (
    DEFAULT_MAX_TORQUE_NM,
    implausible_torque,
    torque_bound_nm,
)
from attitude_core.world.actuator import clip_to_bound
from attitude_core.world.link import StateLink
from attitude_core.world.rigid_body import RigidBody
from attitude_core.world.wheel_plant import WheelPlant

if TYPE_CHECKING:
    from attitude_core.config.node_parameters import SimulatorParams

__all__ = [
    "Action",
    "StepperConfig",
    "StateOut",
    "Decision",
    "SimStepper",
    "SETTLE_S",
    "STARTUP_RESEND_FRACTION",
    "WheeledBody",
]

SETTLE_S = 0.05
"""Wall time the graph must stay connected before the first step, s. The gate itself is
sure: every loop node's per-step outputs have matched the readers the simulator expects
of them, counted by their own writers (``Readiness.min_readers``; the simulator's own
view of the graph can be ahead of a peer's); the settle only absorbs a graph seen
connected for one poll. A link still matching otherwise costs a re-send of the first
state, see :data:`STARTUP_RESEND_FRACTION`."""
STARTUP_RESEND_FRACTION = 0.25
"""Re-send period of the state until the loop has answered once, as a fraction of
``resend_period_s`` (0.05 s by default)."""
PLAUSIBLE_WHEEL_FACTOR = 10.0
"""A wheel's motor torque command beyond this many times its ``max_torque_nm`` is
refused as implausible (within it the wheel clips it)."""
ANSWERABLE_STATES = 100
"""A torque must answer one of the last this many published states (10 s at 0.1 s)."""

Vector = npt.NDArray[np.float64]


class Action(enum.Enum):
    """What a call decided."""

    WAIT = "wait"  # start-up: not connected yet (or settling)
    START = "start"  # start-up: connected; the first state is published
    FAIL = "fail"  # start-up: not connected before startup_timeout_s
    NONE = "none"  # nothing to do
    IGNORE = "ignore"  # lockstep: a torque for another step
    REJECT = "reject"  # an unusable torque; ``reason`` says why
    ACCEPT = "accept"  # real time: the torque is applied from the next step on
    RESEND = "resend"  # lockstep: publish the same state again
    ADVANCE = "advance"  # the body advanced one step with the commanded torque
    HOLD = "hold"  # lockstep timeout: advanced with the last torque held
    ZERO = "zero"  # stale torque: advanced with zero torque
    FINISH = "finish"  # the scenario time has ended; ``exit_code`` 0
    LINK_HOLD = "link_hold"  # lockstep behind a link: no state due, none stale: held torque


@dataclass(frozen=True)
class StepperConfig:
    """The simulator's own parameters (:data:`attitude_core.config.node_parameters.SIMULATOR`)
    and the scenario's step."""

    dt_s: float
    n_steps: int
    time_mode: TimeMode = TimeMode.LOCKSTEP
    resend_period_s: float = 0.2
    torque_timeout_s: float = 2.0
    max_held_steps: int = 1
    torque_stale_s: float = 0.5
    startup_timeout_s: float = 60.0
    max_torque_nm: tuple[float, ...] | None = None  # the plant's bound, per axis
    plausible_torque_nm: tuple[float, ...] = (DEFAULT_MAX_TORQUE_NM,) * 3  # per axis or wheel
    link: LinkSpec | None = None  # the rehearsal link (None: the state goes out as made)
    fdir: FdirConfig | None = None  # the stack's watchdog rule (lockstep behind a link)

    def __post_init__(self) -> None:
        if self.time_mode not in tuple(TimeMode):
            modes = [m.value for m in TimeMode]
            raise ValueError(f"time_mode must be one of {modes}, got {self.time_mode!r}")
        object.__setattr__(self, "time_mode", TimeMode(self.time_mode))

    @classmethod
    def from_parameters(
        cls,
        params: SimulatorParams,
        dt_s: float,
        n_steps: int,
        max_torque_nm: tuple[float, ...] | None = None,
        plausible_torque_nm: tuple[float, ...] = (DEFAULT_MAX_TORQUE_NM,) * 3,
        link: LinkSpec | None = None,
        fdir: FdirConfig | None = None,
    ) -> StepperConfig:
        """From the simulator node's parameters."""
        return cls(
            link=link,
            fdir=fdir,
            max_torque_nm=max_torque_nm,
            plausible_torque_nm=plausible_torque_nm,
            dt_s=dt_s,
            n_steps=n_steps,
            time_mode=params.time_mode,
            resend_period_s=params.lockstep.resend_period_s,
            torque_timeout_s=params.lockstep.torque_timeout_s,
            max_held_steps=params.lockstep.max_held_steps,
            torque_stale_s=params.realtime.torque_stale_s,
            startup_timeout_s=params.startup_timeout_s,
        )


@dataclass(frozen=True)
class StateOut:
    """A state to publish: ``stamp_ns`` on attitude and rate; ``clock_ns`` on ``/clock``
    in lockstep, where it is the simulated time the stamps carry (None in real time:
    there the stamps are the node's clock and no ``/clock`` is published). With wheels:
    their speeds (rad/s) and the motor torques applied over the step that ended here."""

    k: int
    stamp_ns: int
    clock_ns: int | None
    sigma_bn: Vector
    omega_b: Vector
    wheel_speeds: Vector | None = None
    wheel_effort: Vector | None = None


class WheeledBody:
    """A :class:`WheelPlant` as the stepper's body: ``step(motor torques, dt)`` from the
    plant's own time (steps taken times ``dt``)."""

    def __init__(self, plant: WheelPlant) -> None:
        self.plant = plant
        self.steps = 0
        self.effort: Vector = np.zeros(len(plant.array))  # applied over the last step
        self.body_torque_b: Vector = np.zeros(3)

    @property
    def sigma_bn(self) -> Vector:
        return self.plant.sigma_bn

    @property
    def omega_b(self) -> Vector:
        return self.plant.omega_b

    @property
    def speeds(self) -> Vector:
        return self.plant.speeds

    def body_torque_of(self, motor_torque_nm: Vector, dt: float) -> Vector:
        """The body torque the wheels would apply for ``motor_torque_nm`` now (no step)."""
        u = self.plant.applied(motor_torque_nm, self.steps * dt)
        return self.plant.array.body_torque_b(u)

    def step(self, motor_torque_nm: Vector, dt: float) -> None:
        out = self.plant.step(motor_torque_nm, self.steps * dt, dt)
        self.steps += 1
        self.effort, self.body_torque_b = out.motor_torque_nm, out.body_torque_b


@dataclass
class Decision:
    """The outcome of one call. ``applied``: publish this torque, stamped with the
    previous state, as applied over the step just taken. ``state``: publish this state
    (``resend``: the current one again). ``logs``: (level, text) pairs to log.

    Behind a link: ``clocks``, the ``/clock`` stamps to publish first, in order;
    ``truth``, the true state to publish on ``/spacecraft/truth/*``; ``state``, the
    state the link delivered (None: none); ``resend_state`` False when a re-send is of
    ``/clock`` alone (a tick awaiting its answer); ``more``: step again at once
    (:meth:`SimStepper.step_on`)."""

    action: Action
    applied: Vector | None = None
    applied_stamp_ns: int | None = None
    state: StateOut | None = None
    exit_code: int | None = None
    reason: str | None = None
    logs: list[tuple[str, str]] = field(default_factory=list)
    clocks: list[int] = field(default_factory=list)
    truth: StateOut | None = None
    resend_state: bool = True
    more: bool = False

    @property
    def resend(self) -> bool:
        """Publish the current state again (lockstep, its torque still missing)."""
        return self.action is Action.RESEND


class SimStepper:
    """See the module docstring. ``created`` is the wall time the start-up clock starts."""

    def __init__(
        self, config: StepperConfig, body: RigidBody | WheeledBody, created: float
    ) -> None:
        self.cfg = config
        self.body = body
        self.wheeled = isinstance(body, WheeledBody)
        self.dt_ns = int(round(config.dt_s * NS_PER_S))
        self.k = 0
        self.command_size = len(config.plausible_torque_nm)  # 3 axes, or the wheels
        self.torque: Vector = np.zeros(self.command_size)
        self.waiting_stamp: int | None = None  # lockstep: the state awaiting its torque
        self.state_stamp: int | None = None  # stamp of the state last published
        self.published: deque[int] = deque(maxlen=ANSWERABLE_STATES)  # stamps a torque answers
        self.sent_at = self.first_sent_at = 0.0
        self.resends = self.timeouts = self.rejected = 0
        self.saturated_steps = 0  # steps whose torque the plant's bound clipped
        self.held_steps = 0  # lockstep: consecutive timed-out steps
        self.torque_stamp = -1  # real time: stamp of the applied torque
        self.torque_received_at: float | None = None
        self.answered = False  # lockstep: a torque has answered a state
        self.stale = False
        self.done = False
        self.exit_code: int | None = None
        self.created = created
        self.ready_since: float | None = None
        self.started_at: float | None = None
        self.link: StateLink[tuple[int, Vector, Vector]] | None = (
            None if config.link is None else StateLink(config.link)
        )
        self.fdir = config.fdir if config.fdir is not None else FdirConfig.for_step(config.dt_s)
        self.delivered_ns: int | None = None  # stamp of the newest state the link delivered
        self.pending_clock_ns: int | None = None  # lockstep link: /clock after the answer
        self.tick_wait = False  # lockstep link: the awaited torque answers a tick

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, parameters: SimulatorParams, created: float
    ) -> SimStepper:
        """The stepper of a scenario's body, with the simulator node's parameters."""
        if scenario.wheels is not None:
            array = scenario.wheels
            wheel_plant = WheelPlant(
                scenario.inertia_kgm2,
                array,
                scenario.initial_mrp,
                scenario.initial_rate_rad_s,
                scenario.disturbances,
            )
            plausible = tuple(float(x) * PLAUSIBLE_WHEEL_FACTOR for x in array.max_torque)
            wheel_config = StepperConfig.from_parameters(
                parameters, scenario.dt_s, scenario.n_steps, None, plausible, None, None
            )
            return cls(wheel_config, WheeledBody(wheel_plant), created)
        declared = scenario.actuators.max_torque_nm
        weaker = float(parameters.fault.wheel_torque_fraction)
        plant = None if declared is None else (
            float(declared[0]) * weaker,
            float(declared[1]) * weaker,
            float(declared[2]) * weaker,
        )  # fmt: skip
        config = StepperConfig.from_parameters(
            parameters,
            scenario.dt_s,
            scenario.n_steps,
            plant,
            torque_bound_nm(scenario),
            scenario.link,
            None if scenario.link is None else scenario.watchdog,
        )
        body = RigidBody(scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s)
        return cls(config, body, created)

    @property
    def lockstep(self) -> bool:
        return self.cfg.time_mode is TimeMode.LOCKSTEP

    # -- start-up -------------------------------------------------------------------

    def poll_graph(self, now: float, ready: bool) -> Decision:
        """Called periodically before the first step; START publishes the first state
        in lockstep (real time: call :meth:`on_timer` at once, then every ``dt_s``)."""
        if self.started_at is not None or self.done:
            return Decision(Action.NONE)
        if not ready:
            self.ready_since = None
            if now - self.created > self.cfg.startup_timeout_s:
                self._finish(1)
                return Decision(
                    Action.FAIL,
                    exit_code=1,
                    logs=[("error", f"graph not connected after {self.cfg.startup_timeout_s} s")],
                )
            return Decision(Action.WAIT)
        if self.ready_since is None:
            self.ready_since = now
        if now - self.ready_since < SETTLE_S:
            return Decision(Action.WAIT)
        self.started_at = now
        decision = Decision(Action.START, logs=[("info", "graph connected; starting")])
        if self.lockstep and self.link is not None:
            self._linked_step(now, decision)
        elif self.lockstep:
            decision.state = self._state(now, self.k * self.dt_ns)
        return decision

    # -- inputs ---------------------------------------------------------------------

    def on_torque(
        self,
        now: float,
        stamp_ns: int,
        torque: Vector | Sequence[float],
        frame_id: str = BODY_FRAME,
        malformed: str | None = None,
    ) -> Decision:
        """A commanded torque (body axes, N m) stamped ``stamp_ns``, in ``frame_id``;
        ``malformed``: why the message could not be read (refused and counted)."""
        if malformed:
            return self._reject(f"malformed message: {malformed}")
        u = np.asarray(torque, dtype=float)
        if frame_id != BODY_FRAME:
            return self._reject(f"frame_id {frame_id!r}, expected {BODY_FRAME!r}")
        if u.shape != (self.command_size,):
            return self._reject(f"{u.size} torques for {self.command_size}")
        reason = implausible_torque(u.tolist(), self.cfg.plausible_torque_nm, self.wheeled)
        if reason:
            return self._reject(reason)
        if self.done or self.started_at is None:
            return Decision(Action.IGNORE)
        if not self._answerable(stamp_ns):  # the step it answers decides, not its stamp
            return self._reject(
                f"stamp {stamp_ns} ns answers no state this simulator published "
                f"(the last is {self.state_stamp} ns)"
            )
        if not self.lockstep:
            if stamp_ns < self.torque_stamp:
                return self._reject(
                    f"stamp {stamp_ns} ns is older than the applied torque's {self.torque_stamp} ns"
                )
            self.torque, self.torque_stamp = u, stamp_ns
            self.torque_received_at = now
            return Decision(Action.ACCEPT, logs=self._set_stale(False))
        if stamp_ns != self.waiting_stamp:
            return Decision(Action.IGNORE)
        self.held_steps = 0
        self.answered = True
        logs = self._set_stale(False)
        decision = self._advance(now, u, Action.ADVANCE)
        decision.logs[:0] = logs
        return decision

    def reject(self, reason: str) -> Decision:
        """A command the node could not read (e.g. a wheel missing): refused, counted."""
        return self._reject(reason)

    def on_timer(self, now: float, clock_ns: int = 0) -> Decision:
        """Lockstep: the torque deadline check (call often, e.g. every 20 ms). Real time:
        one step (call every ``dt_s``; ``clock_ns`` is the node's clock, the stamp)."""
        if self.done or self.started_at is None:
            return Decision(Action.NONE)
        return self._deadline(now) if self.lockstep else self._tick(now, clock_ns)

    # -- lockstep -------------------------------------------------------------------

    def _deadline(self, now: float) -> Decision:
        if self.waiting_stamp is None:
            return Decision(Action.NONE)
        timeout = self.cfg.torque_timeout_s if self.answered else self.cfg.startup_timeout_s
        if now - self.first_sent_at > timeout:
            self.timeouts += 1
            self.held_steps += 1
            if self.held_steps > self.cfg.max_held_steps:
                logs = self._set_stale(True)
                self.torque = np.zeros(self.command_size)
                action = Action.ZERO
            else:
                logs = [
                    (
                        "warning",
                        f"no torque for step {self.k} after "
                        f"{timeout} s; holding the last torque "
                        f"{self.torque.tolist()} N m",
                    )
                ]
                action = Action.HOLD
            decision = self._advance(now, self.torque, action)
            decision.logs[:0] = logs
            return decision
        period = self.cfg.resend_period_s
        if not self.answered:  # the first state: a node that missed it is still matching
            period *= STARTUP_RESEND_FRACTION
        if now - self.sent_at > period:
            self.resends += 1
            self.sent_at = now
            if self.tick_wait:  # the tick's /clock again: there is no state to re-send
                return Decision(Action.RESEND, clocks=[self.waiting_stamp], resend_state=False)
            return Decision(Action.RESEND)
        return Decision(Action.NONE)

    def step_on(self, now: float) -> Decision:
        """Lockstep behind a link, after a decision with ``more``: the next step, the
        last torque held (no state was due and none is stale)."""
        if self.done or self.waiting_stamp is not None or self.link is None:
            return Decision(Action.NONE)
        return self._advance(now, self.torque, Action.LINK_HOLD)

    def _advance(self, now: float, torque: Vector, action: Action) -> Decision:
        """The torque for step k is known: integrate to k + 1 and publish that state."""
        self.torque = torque
        self.waiting_stamp = None
        self.tick_wait = False
        applied, applied_stamp = self._bounded(torque), self.state_stamp
        if self.k >= self.cfg.n_steps:  # nothing flown: what the plant would apply
            if isinstance(self.body, WheeledBody):
                applied = self.body.body_torque_of(applied, self.cfg.dt_s)
            decision = self._end(now, applied)
            decision.applied_stamp_ns = applied_stamp
            return decision
        self.body.step(applied, self.cfg.dt_s)
        if not self._finite_state():
            return self._diverged()
        applied = self._applied_b(applied)
        self.k += 1
        if self.link is not None:
            decision = Decision(action, applied=applied, applied_stamp_ns=applied_stamp)
            self._linked_step(now, decision)
            return decision
        return Decision(
            action,
            applied=applied,
            applied_stamp_ns=applied_stamp,
            state=self._state(now, self.k * self.dt_ns),
        )

    # -- real time ------------------------------------------------------------------

    def _tick(self, now: float, clock_ns: int) -> Decision:
        if self.k > self.cfg.n_steps:
            return self._end(now, None)
        logs: list[tuple[str, str]] = []
        action = Action.ADVANCE
        if (
            self.torque_received_at is not None
            and now - self.torque_received_at > self.cfg.torque_stale_s
        ):
            logs = self._set_stale(True)
            self.torque = np.zeros(self.command_size)
            self.torque_received_at = None
        if self.stale:
            action = Action.ZERO
        applied, applied_stamp = None, None
        if self.k > 0:
            applied, applied_stamp = self._bounded(self.torque), self.state_stamp
            self.body.step(applied, self.cfg.dt_s)
            if not self._finite_state():
                return self._diverged()
            applied = self._applied_b(applied)
        if self.link is not None:
            decision = Decision(action, applied=applied, applied_stamp_ns=applied_stamp, logs=logs)
            self._linked_realtime(now, clock_ns, decision)
            self.k += 1
            return decision
        state = self._state(now, clock_ns)
        self.k += 1
        return Decision(
            action, applied=applied, applied_stamp_ns=applied_stamp, state=state, logs=logs
        )

    # -- behind a link ----------------------------------------------------------------

    def _linked_step(self, now: float, decision: Decision) -> None:
        """Lockstep: the body is at step ``k``: what the link delivers, what to await."""
        if self.pending_clock_ns is not None:  # the previous step's tick, after its answer
            decision.clocks.append(self.pending_clock_ns)
            self.pending_clock_ns = None
        assert self.link is not None
        stamp = self.k * self.dt_ns
        decision.truth = self._truth(stamp)
        self.link.send(stamp, (self.k, self.body.sigma_bn.copy(), self.body.omega_b.copy()))
        got = self.link.receive(stamp)
        self.sent_at = self.first_sent_at = now
        if got is not None:
            s, (k, sigma, omega) = got
            self.delivered_ns = s
            self._answerable_add(s)
            self.waiting_stamp, self.pending_clock_ns = s, stamp
            decision.state = StateOut(k, s, None, sigma, omega)
            return
        decision.clocks.append(stamp)
        if self.delivered_ns is not None and self.fdir.stale(stamp - self.delivered_ns):
            self._answerable_add(stamp)  # the stack answers this tick
            self.waiting_stamp, self.tick_wait = stamp, True
            return
        decision.more = not self.done

    def _linked_realtime(self, now: float, clock_ns: int, decision: Decision) -> None:
        """Real time: the step's true state, and what the link delivers by now."""
        assert self.link is not None
        decision.truth = self._truth(clock_ns)
        self.link.send(clock_ns, (self.k, self.body.sigma_bn.copy(), self.body.omega_b.copy()))
        got = self.link.receive(clock_ns)
        if got is not None:
            s, (k, sigma, omega) = got
            self.delivered_ns = s
            decision.state = StateOut(k, s, None, sigma, omega)

    def _truth(self, stamp_ns: int) -> StateOut:
        """The true state of step ``k``, stamped ``stamp_ns`` (behind a link)."""
        self.state_stamp = stamp_ns
        self._answerable_add(stamp_ns)
        clock = stamp_ns if self.lockstep else None
        return StateOut(
            self.k, stamp_ns, clock, self.body.sigma_bn.copy(), self.body.omega_b.copy()
        )

    def _answerable_add(self, stamp_ns: int) -> None:
        if not self.published or self.published[-1] < stamp_ns:
            self.published.append(stamp_ns)

    def _answerable(self, stamp_ns: int) -> bool:
        """A torque stamped ``stamp_ns`` answers a state this simulator published (in
        real time: within their span, or one step after the last: a tick's answer)."""
        if stamp_ns in self.published:
            return True
        if self.lockstep or not self.published:
            return False
        return self.published[0] <= stamp_ns <= self.published[-1] + self.dt_ns

    # -- shared ---------------------------------------------------------------------

    def _state(self, now: float, stamp_ns: int) -> StateOut:
        clock_ns = self.k * self.dt_ns if self.lockstep else None
        self.state_stamp = stamp_ns
        if not self.published or self.published[-1] != stamp_ns:
            self.published.append(stamp_ns)
        if self.lockstep:
            self.waiting_stamp = stamp_ns
        self.sent_at = self.first_sent_at = now
        body = self.body
        if isinstance(body, WheeledBody):
            return StateOut(
                self.k,
                stamp_ns,
                clock_ns,
                body.sigma_bn.copy(),
                body.omega_b.copy(),
                body.speeds.copy(),
                body.effort.copy(),
            )
        return StateOut(self.k, stamp_ns, clock_ns, body.sigma_bn.copy(), body.omega_b.copy())

    def _applied_b(self, command: Vector) -> Vector:
        """The body torque of the step just taken (with wheels: what they applied)."""
        body = self.body
        return body.body_torque_b.copy() if isinstance(body, WheeledBody) else command

    def _bounded(self, torque: Vector) -> Vector:
        """The torque the body gets: clipped per axis to the plant's bound, as independent
        wheels saturate (:func:`attitude_core.world.actuator.clip_to_bound`). With wheels,
        the command as sent: the wheel plant applies each wheel's limits."""
        if isinstance(self.body, WheeledBody):
            array = self.body.plant.array
            self.saturated_steps += int(np.any(np.abs(torque) > array.max_torque))
            return np.asarray(torque, dtype=float)
        applied, saturated = clip_to_bound(torque, self.cfg.max_torque_nm)
        self.saturated_steps += int(saturated)
        return np.array(applied, dtype=float)

    def _finite_state(self) -> bool:
        return bool(np.isfinite(self.body.sigma_bn).all() and np.isfinite(self.body.omega_b).all())

    def _diverged(self) -> Decision:
        """The state is no longer finite: stop, never publish it."""
        self._finish(1)
        text = f"state became non-finite at step {self.k}: stopping (nothing more is published)"
        return Decision(Action.FAIL, exit_code=1, logs=[("error", text)])

    def _reject(self, reason: str) -> Decision:
        self.rejected += 1
        return Decision(Action.REJECT, reason=reason)

    def _set_stale(self, stale: bool) -> list[tuple[str, str]]:
        logs = []
        if stale and not self.stale:
            logs.append(
                ("error", "torque is stale: applying zero torque until a controller answers again")
            )
        elif self.stale and not stale:
            logs.append(("info", "torque received again"))
        self.stale = stale
        return logs

    def _end(self, now: float, applied: Vector | None) -> Decision:
        self._finish(0)
        wall = now - (self.started_at if self.started_at is not None else now)
        n = self.cfg.n_steps
        text = (
            f"scenario time ended: {n} steps in {wall:.3f} s wall "
            f"({n / max(wall, 1e-9):.0f} steps/s); {self.resends} re-sends, "
            f"{self.timeouts} torque timeouts, {self.rejected} rejected torques"
        )
        return Decision(Action.FINISH, applied=applied, exit_code=0, logs=[("info", text)])

    def _finish(self, code: int) -> None:
        self.done, self.exit_code = True, code
