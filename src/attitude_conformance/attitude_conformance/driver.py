"""The scripted sequence the tool plays as planner and controller (pure, no ROS).

States are counted in order of arrival (attitude and rate of one stamp both in). State
``i`` is answered with :func:`torque` ``(i)`` stamped with its stamp: 20 non-zero torques,
10 zero, then non-zero again. Lockstep: state 30's torque is withheld ``RESEND_WITHHOLD_S``
(re-sends), state 33's and the ``max_held_steps`` after it are not answered (held step,
then zero torque), the next is; the check ends at state 37. Real time: after state 32
nothing is answered for ``torque_stale_s + 0.7 s``, then three more states are answered.
The script stops early (``aborted``) when the bridge stops producing states.

With wheels (``wheels.*``) the answers are motor torques (:func:`wheel_torque`: some
beyond the wheels' ``max_torque_nm``, to be clipped), sent with the wheel names in an
order that changes from state to state (:func:`wheel_order`: read by name).
"""

from __future__ import annotations

import math

import numpy as np

from .record import Recording, Window

NONZERO_STEPS, ZERO_STEPS = 20, 10
RESEND_AT = NONZERO_STEPS + ZERO_STEPS  # 30
STALE_AT = RESEND_AT + 3  # 33
RESEND_WITHHOLD_S = 0.5
REALTIME_EXTRA_S = 0.7  # real time: withhold this much beyond torque_stale_s
TAIL_STATES = 3  # answered after the stale stretch


def torque(i: int) -> np.ndarray:
    """The scripted torque of state ``i``, N m, body axes: non-zero and varying, except zero
    for states 20 to 29."""
    if NONZERO_STEPS <= i < RESEND_AT:
        return np.zeros(3)
    return 0.02 * np.array(
        (1.0 + 0.5 * math.sin(0.9 * i), -1.0 + 0.5 * math.cos(1.3 * i), 0.5 * math.sin(0.7 * i + 1))
    )


def wheel_torque(i: int, max_torque_nm: np.ndarray) -> np.ndarray:
    """The scripted motor torques of state ``i`` (N m, the scenario's wheel order): zero for
    states 20 to 29 as :func:`torque`; else varying, up to 1.5 times each wheel's limit on
    every third state (those are clipped), 0.8 times otherwise."""
    if NONZERO_STEPS <= i < RESEND_AT:
        return np.zeros(len(max_torque_nm))
    scale = 1.5 if i % 3 == 1 else 0.8
    j = np.arange(len(max_torque_nm))
    return scale * np.asarray(max_torque_nm) * np.sin(0.9 * i + 1.7 * j + 0.4)


def wheel_order(i: int, n: int) -> tuple[int, ...]:
    """The order of the ``n`` wheels in the command of state ``i`` (indices into the
    scenario's order): rotated by ``i``, so most commands are not in the declared order."""
    return tuple((j + i) % n for j in range(n))


class Driver:
    """Decides, from the arrival of states and the time, which torques to send."""

    def __init__(self, rec: Recording) -> None:
        self.rec = rec
        lim, dt = rec.setup.limits, rec.setup.dt_s
        self.lockstep = rec.setup.lockstep
        self.resend_withhold_s = min(RESEND_WITHHOLD_S, 0.5 * lim.torque_timeout_s)
        self.step_wait_s = 0.75 * lim.torque_timeout_s if self.lockstep else 5.0 * dt + 1.0
        self.stale_wait_s = lim.torque_timeout_s + 2.0
        self.index: dict[int, int] = {}  # stamp -> state index
        self.answers: dict[int, np.ndarray] = {}  # stamp -> torque sent
        self.last_new_s: float | None = None  # arrival of the newest state
        self.waiting_since = 0.0  # the newest state's arrival or the last answer, later one
        self.withheld: tuple[str, int, float] | None = None  # (kind, stamp, since)
        self.stale_end_i: int | None = None
        self.done = False
        wheels = rec.setup.wheels
        self.command = torque if wheels is None else (lambda i: wheel_torque(i, wheels.max_torque))

    @property
    def n(self) -> int:
        return len(self.index)

    def _answer(self, stamp: int, i: int, now: float) -> list[tuple[int, np.ndarray]]:
        u = self.command(i)
        self.answers[stamp] = u
        self.waiting_since = now
        return [(stamp, u)]

    def on_state(self, stamp: int, now: float) -> list[tuple[int, np.ndarray]]:
        """A state is complete (first time or re-sent): the torques to send now."""
        if self.done:
            return []
        if stamp in self.index:  # a re-send: answer it again unless withheld
            held = self.withheld is not None and self.withheld[1] == stamp
            return [] if held or stamp not in self.answers else [(stamp, self.answers[stamp])]
        i = self.n
        self.index[stamp] = i
        self.last_new_s = self.waiting_since = now
        return (
            self._lockstep_new(stamp, i, now)
            if self.lockstep
            else self._realtime_new(stamp, i, now)
        )

    def _lockstep_new(self, stamp: int, i: int, now: float) -> list[tuple[int, np.ndarray]]:
        held = self.rec.setup.limits.max_held_steps
        if i == RESEND_AT:
            self.withheld = ("resend", stamp, now)
            return []
        if i == STALE_AT:
            self.withheld = ("stale", stamp, now)
            return []
        if STALE_AT < i <= STALE_AT + held:
            return []
        if i == STALE_AT + held + 1:
            self._close(now)
        if i >= STALE_AT + held + TAIL_STATES:
            self.done = True
            return []
        return self._answer(stamp, i, now)

    def _realtime_new(self, stamp: int, i: int, now: float) -> list[tuple[int, np.ndarray]]:
        if self.withheld is not None:
            since = self.withheld[2]
            if now - since < self.rec.setup.limits.torque_stale_s + REALTIME_EXTRA_S:
                return []
            self._close(now)
            self.stale_end_i = i
        if self.stale_end_i is not None and i >= self.stale_end_i + TAIL_STATES:
            self.done = True
            return []
        if i == STALE_AT and self.stale_end_i is None:
            last = self.rec.torques[-1].wall_s if self.rec.torques else now
            self.withheld = ("stale", stamp, last)
            return []
        return self._answer(stamp, i, now)

    def _close(self, now: float) -> None:
        """End the withholding stretch now (the torque about to be sent ends it)."""
        if self.withheld is not None:
            kind, stamp, since = self.withheld
            self.rec.windows.append(Window(kind, stamp, since, now))
            self.withheld = None

    def on_tick(self, now: float) -> list[tuple[int, np.ndarray]]:
        """Called often: ends the re-send stretch, gives up when the bridge stalls."""
        if self.done or self.last_new_s is None:
            return []
        w = self.withheld
        if w is not None and w[0] == "resend" and now - w[2] >= self.resend_withhold_s:
            self._close(now)
            return self._answer(w[1], self.index[w[1]], now)
        stalled = now - self.waiting_since
        limit = self.stale_wait_s if w is not None and w[0] == "stale" else self.step_wait_s
        if w is not None and w[0] == "resend":
            limit = self.resend_withhold_s + self.step_wait_s
        if stalled > limit:
            last = next(reversed(self.index))  # the newest state's stamp
            if w is not None:
                why = f"while the torque of the state stamped {last} ns was withheld"
            elif self.lockstep:
                why = f"after the torque stamped {last} ns, the stamp of its newest state"
            else:
                why = f"after the state stamped {last} ns (real time: one every dt)"
            self.abort(f"no new state within {stalled:.2f} s {why}", now)
        return []

    def abort(self, reason: str, now: float) -> None:
        """Stop the script; a withholding stretch under way ends now."""
        if not self.done:
            self.rec.aborted = reason
            self._close(now)
            self.done = True
