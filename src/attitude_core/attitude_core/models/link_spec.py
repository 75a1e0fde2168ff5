"""The declared link between the plant and the stack (``link.*``): a rehearsal of a
hardware-in-the-loop bench in our simulator.

What both sides read: the world's link (:mod:`attitude_core.world.link`) delays, drops
and withholds the states the plant publishes with it; the scenario checks it against the
flight software's watchdog (``fdir.*``). Seconds of simulated time (the stamps' time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["LinkSpec"]


@dataclass(frozen=True)
class LinkSpec:
    """``state_latency_s``: every state arrives this late, plus a uniform draw in
    ``[-jitter_s, +jitter_s]`` (never before its stamp); ``drop_rate``: the share of
    states lost; ``outages``: ``(start_s, duration_s)`` windows whose states are withheld
    (never delivered); ``seed``: the draws. ``/clock`` is never impaired."""

    state_latency_s: float = 0.0
    jitter_s: float = 0.0
    drop_rate: float = 0.0
    outages: tuple[tuple[float, float], ...] = ()
    seed: int = 0

    def problem(self) -> str | None:
        """Why this link is not usable (None: it is)."""
        for name in ("state_latency_s", "jitter_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                return f"link.{name}: must be >= 0, got {v!r}"
        if not 0.0 <= self.drop_rate < 1.0:
            return f"link.drop_rate: must be in [0, 1), got {self.drop_rate!r}"
        for start, duration in self.outages:
            if start < 0.0 or duration <= 0.0:
                return (
                    "link.outages: each pair is a start >= 0 and a duration > 0 (s), "
                    f"got [{start}, {duration}]"
                )
        return None

    def withheld(self, t_s: float) -> bool:
        """The state stamped ``t_s`` falls in an outage."""
        return any(start <= t_s < start + duration for start, duration in self.outages)
