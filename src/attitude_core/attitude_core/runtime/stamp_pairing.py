"""The planner's and the controller's intake, without ROS: inputs paired by stamp.

A receiver answers each stamp once, when every one of its inputs (its *slots*: the
attitude and the rate for the planner; those and the target's MRP and rate for the
controller) has arrived with that stamp. :class:`StampPairing` decides, for each
incoming message, in this order:

1. the stamp (:class:`attitude_core.runtime.stamp_gate.StampGate`): the stamp last answered
   again is a lockstep re-send (:attr:`Intake.REPEAT`: answer it again, identically);
   an implausible stamp is refused and counted by the gate;
2. the content (the caller's reason: wrong frame, non-finite, implausible): refused and
   counted here;
3. the pairing: the value waits in its slot (:attr:`Intake.WAITING`) until the stamp's
   other slots are in (:attr:`Intake.COMPLETE`, with the values in slot order); the
   stamp then becomes the gate's reference and every pending stamp up to it is
   dropped. At most ``pending_max`` stamps wait; the oldest goes first.

:attr:`StampPairing.rejected` counts every refused message, for stamp or content.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from attitude_core.contract.topics import NS_PER_S
from attitude_core.runtime.stamp_gate import StampGate

__all__ = ["Intake", "Offer", "StampPairing", "PENDING_MAX"]

PENDING_MAX = 64
"""Stamps kept while waiting for their other inputs."""


class Intake(enum.Enum):
    """What became of one incoming message."""

    REPEAT = "repeat"  # the stamp last answered, again
    REJECTED = "rejected"  # refused (``reason``), counted
    WAITING = "waiting"  # kept until the stamp's other inputs arrive
    COMPLETE = "complete"  # the stamp's inputs are all in: answer it


@dataclass(frozen=True)
class Offer:
    """The outcome of :meth:`StampPairing.offer`. ``reason``: why it was refused, or
    (accepted) a note worth a warning (the gate re-anchored); ``rejected``: the total
    refused so far; ``stamp_ns`` and ``values`` (slot order) on :attr:`Intake.COMPLETE`."""

    intake: Intake
    reason: str = ""
    rejected: int = 0
    stamp_ns: int = 0
    values: tuple[Any, ...] = ()


class StampPairing:
    """Pairs ``slots`` inputs by stamp through ``gate``; see the module docstring."""

    def __init__(self, slots: int, gate: StampGate, pending_max: int = PENDING_MAX) -> None:
        if slots < 1 or pending_max < 1:
            raise ValueError(f"slots ({slots}) and pending_max ({pending_max}) must be >= 1")
        self.slots = slots
        self.gate = gate
        self.pending_max = pending_max
        self.pending: dict[int, list[Any]] = {}
        self.bad_values = 0  # refused for their content

    @property
    def rejected(self) -> int:
        """Refused messages: implausible stamps (the gate's count) and bad values."""
        return self.gate.rejected + self.bad_values

    def newest_with(self, slots: tuple[int, ...]) -> tuple[int, list[Any]] | None:
        """The newest pending stamp whose ``slots`` are all in, and its inputs (None:
        none): e.g. a state whose target has not come yet."""
        for stamp in sorted(self.pending, reverse=True):
            inputs = self.pending[stamp]
            if all(inputs[k] is not None for k in slots):
                return stamp, inputs
        return None

    def offer(
        self,
        slot: int,
        sec: int,
        nanosec: int,
        wall_ns: int,
        value: Any,
        reason: str | None = None,
    ) -> Offer:
        """A message for ``slot`` stamped ``sec``/``nanosec``, received at this host's
        ``wall_ns``, carrying ``value``; ``reason`` is why its content is unusable."""
        verdict = self.gate.screen(sec, nanosec, wall_ns)
        if verdict.repeat:
            return Offer(Intake.REPEAT)
        if not verdict.accept:
            return Offer(Intake.REJECTED, verdict.reason, self.rejected)
        if reason:
            self.bad_values += 1
            return Offer(Intake.REJECTED, reason, self.rejected)
        stamp = sec * NS_PER_S + nanosec
        inputs = self.pending.setdefault(stamp, [None] * self.slots)
        inputs[slot] = value
        if any(x is None for x in inputs):
            while len(self.pending) > self.pending_max:
                del self.pending[min(self.pending)]
            return Offer(Intake.WAITING, verdict.reason)
        self.gate.take(stamp, wall_ns)
        for old in [s for s in self.pending if s <= stamp]:
            del self.pending[old]
        return Offer(Intake.COMPLETE, verdict.reason, stamp_ns=stamp, values=tuple(inputs))
