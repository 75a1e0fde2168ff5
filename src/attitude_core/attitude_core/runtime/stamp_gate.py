"""Which incoming stamps a receiver may take as its time reference.

The planner and the controller answer each state stamp once and refuse a stamp older
than the last one answered. Without a gate, one message stamped in the future becomes
that reference and locks every real state out (a stamp 1000 s ahead: 572 states
refused, zero torque, a timed-out run). :class:`StampGate` screens each stamp first:

* **Well-formed:** ``sec >= 0`` and ``0 <= nanosec < 1e9``.
* **On the run's timeline:** a lockstep run's stamps are simulated time, in
  ``[0, sim_time_s + TIMELINE_SLACK_S]``; a real-time run's are the plant's clock,
  at most :data:`MAX_LEAD_S` ahead of this host's clock (and at most
  :data:`MAX_LAG_S` behind). The first accepted stamp fixes which; a stamp that fits
  neither is refused.
* **Continuous:** at most :data:`MAX_JUMP_S` ahead of the last accepted stamp, and not
  older than it (equal: a lockstep re-send, answered again by the caller).

A refused stamp is counted and never becomes the reference. If the reference itself
was wrong (the plant really restarted its clock, or a stray stamp got through before
the gate knew the timeline), the gate re-anchors after :data:`REANCHOR_AFTER`
consecutive refused stamps that are plausible on the timeline and form an increasing
stream with steps of at most ``MAX_JUMP_S``: one stray message can never lock the
loop out for good, and one stray message can never move the reference.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from attitude_core.contract.topics import NS_PER_S

__all__ = [
    "MAX_LEAD_S",
    "MAX_LAG_S",
    "MAX_JUMP_S",
    "REANCHOR_AFTER",
    "TIMELINE_SLACK_S",
    "Timeline",
    "Verdict",
    "StampGate",
    "stamp_fields_reason",
    "timelines",
]

MAX_LEAD_S = 1.0
"""How far ahead of this host's clock a real-time stamp may be, s (same-host or
synchronised clocks)."""
MAX_LAG_S = 60.0
"""How far behind this host's clock a real-time stamp may be, s."""
MAX_JUMP_S = 5.0
"""Largest step between consecutive accepted stamps, s (50 steps of 0.1 s)."""
TIMELINE_SLACK_S = 10.0
"""Simulated-time stamps may run this far past the scenario's end (the settle), s."""
REANCHOR_AFTER = 10
"""Consecutive refused but mutually consistent stamps that move the reference."""


class Timeline(enum.Enum):
    SIMULATED = "simulated time"  # lockstep: 0 .. sim_time_s
    WALL = "this host's clock"  # real time: stamps of the plant's clock


@dataclass(frozen=True)
class Verdict:
    """``accept``: a new stamp to answer; ``repeat``: the last one again; otherwise
    ``reason`` says why it is refused."""

    accept: bool
    repeat: bool = False
    reason: str = ""


_REPEAT = Verdict(False, repeat=True)
_NEW = Verdict(True)


def timelines(stamp_ns: int, wall_ns: int, sim_time_s: float) -> tuple[Timeline, ...]:
    """The timelines a (well-formed) stamp received at ``wall_ns`` can be on."""
    fits = []
    if stamp_ns <= (sim_time_s + TIMELINE_SLACK_S) * NS_PER_S:
        fits.append(Timeline.SIMULATED)
    if wall_ns - MAX_LAG_S * NS_PER_S <= stamp_ns <= wall_ns + MAX_LEAD_S * NS_PER_S:
        fits.append(Timeline.WALL)
    return tuple(fits)


def stamp_fields_reason(sec: int, nanosec: int) -> str | None:
    """Why a ``builtin_interfaces/Time`` is malformed, else None."""
    if sec < 0:
        return f"stamp has negative seconds (sec = {sec})"
    if not 0 <= nanosec < NS_PER_S:
        return f"stamp nanosec = {nanosec} is not in [0, 1e9)"
    return None


@dataclass
class StampGate:
    """Screens stamps (integer ns) for one receiver; see the module docstring.

    ``screen(stamp, wall_ns)`` classifies a stamp without taking it; ``take(stamp)``
    makes it the reference once the caller has answered it.
    """

    sim_time_s: float
    timeline: Timeline | None = None
    last_ns: int | None = None
    rejected: int = 0
    _suspects: list[int] = field(default_factory=list)

    def screen(self, sec: int, nanosec: int, wall_ns: int) -> Verdict:
        """Classify the stamp ``sec``/``nanosec`` received at this host's ``wall_ns``."""
        reason = stamp_fields_reason(sec, nanosec)
        if reason:
            return self._refuse(reason, None)
        stamp = sec * NS_PER_S + nanosec
        fits = self._timelines(stamp, wall_ns)
        timeline = self.timeline
        if (timeline is None and not fits) or (timeline is not None and timeline not in fits):
            where = (
                f"[0, {self.sim_time_s + TIMELINE_SLACK_S:g}] s of simulated time",
                f"-{MAX_LAG_S:g} s .. +{MAX_LEAD_S:g} s of this host's clock",
            )
            allowed = (
                " or ".join(where)
                if timeline is None
                else where[0 if timeline is Timeline.SIMULATED else 1]
            )
            return self._refuse(f"stamp {stamp / NS_PER_S:.9f} s is not within {allowed}", None)
        last = self.last_ns
        if last is None:
            return _NEW
        if stamp == last:
            return _REPEAT
        if stamp < last:
            why = f"stamp {stamp} ns is older than the last answered {last} ns"
        elif stamp - last > MAX_JUMP_S * NS_PER_S:
            why = (
                f"stamp {stamp} ns jumps {(stamp - last) / NS_PER_S:.3f} s ahead of the last "
                f"answered {last} ns (more than {MAX_JUMP_S:g} s)"
            )
        else:
            self._suspects.clear()
            return _NEW
        return self._refuse(why, stamp)

    def take(self, stamp_ns: int, wall_ns: int) -> None:
        """``stamp_ns`` was answered: it is the reference from now on."""
        if self.timeline is None:
            fits = self._timelines(stamp_ns, wall_ns)
            self.timeline = Timeline.SIMULATED if Timeline.SIMULATED in fits else Timeline.WALL
        self.last_ns = stamp_ns
        self._suspects.clear()

    def _timelines(self, stamp: int, wall_ns: int) -> tuple[Timeline, ...]:
        return timelines(stamp, wall_ns, self.sim_time_s)

    def _refuse(self, reason: str, stamp: int | None) -> Verdict:
        """Count a refusal; re-anchor on a consistent stream of refused stamps."""
        if stamp is not None:
            suspects = self._suspects
            if suspects and stamp == suspects[-1]:
                pass  # the other half of a pair: no new evidence
            elif suspects and 0 < stamp - suspects[-1] <= MAX_JUMP_S * NS_PER_S:
                suspects.append(stamp)
            else:
                suspects[:] = [stamp]
            if len(suspects) >= REANCHOR_AFTER:
                suspects.clear()
                self.last_ns = None  # the stream is the truth: answer it from here
                return Verdict(
                    True,
                    reason=f"re-anchored on a consistent stream of {REANCHOR_AFTER} stamps "
                    "after the reference was refused",
                )
        self.rejected += 1
        return Verdict(False, reason=reason)
