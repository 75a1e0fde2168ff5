"""The rehearsal link: what a bench's network does to the states the plant publishes.

Input: each state the plant makes (:meth:`StateLink.send`, its stamp in ns and a
payload). Output: at each time of the stack's clock (:meth:`StateLink.receive`, ns), the
newest state due by then that is newer than the last delivered (older ones arriving
late are overtaken: the stack would refuse them), or None. A state stamped in an
outage window is withheld; one is lost with probability ``drop_rate``; the others are
due ``state_latency_s`` plus a uniform draw in ``[-jitter_s, +jitter_s]`` after their
stamp (never before it). Two draws per state, whatever becomes of it, from one
generator seeded by ``link.seed``: a run is reproducible, and an outage does not shift
the later draws. Outage windows are in seconds since the first state sent (the
simulated time in lockstep, the run's time in real time).
"""

from __future__ import annotations

import heapq
from typing import Generic, TypeVar

import numpy as np

from attitude_core.models.link_spec import LinkSpec

__all__ = ["StateLink", "NS_PER_S"]

NS_PER_S = 1_000_000_000
_P = TypeVar("_P")


class StateLink(Generic[_P]):
    """See the module docstring."""

    def __init__(self, spec: LinkSpec) -> None:
        self.spec = spec
        self.rng = np.random.default_rng(spec.seed)
        self.pending: list[tuple[int, int, int, _P]] = []  # (due, stamp, order, payload)
        self.order = 0
        self.last_ns: int | None = None  # stamp of the newest delivered state
        self.origin_ns: int | None = None  # stamp of the first state sent (t = 0)
        self.sent = self.lost = self.withheld = self.overtaken = self.delivered = 0

    def send(self, stamp_ns: int, payload: _P) -> None:
        """The plant published the state stamped ``stamp_ns``."""
        spec = self.spec
        u_drop, u_jitter = self.rng.random(2)
        self.sent += 1
        if self.origin_ns is None:
            self.origin_ns = stamp_ns
        if spec.withheld((stamp_ns - self.origin_ns) / NS_PER_S):
            self.withheld += 1
            return
        if u_drop < spec.drop_rate:
            self.lost += 1
            return
        delay = max(0.0, spec.state_latency_s + spec.jitter_s * (2.0 * float(u_jitter) - 1.0))
        due = stamp_ns + round(delay * NS_PER_S)
        heapq.heappush(self.pending, (due, stamp_ns, self.order, payload))
        self.order += 1

    def receive(self, now_ns: int) -> tuple[int, _P] | None:
        """The newest state due at ``now_ns`` and newer than the last delivered:
        ``(stamp_ns, payload)``; None when there is none."""
        best: tuple[int, _P] | None = None
        while self.pending and self.pending[0][0] <= now_ns:
            _, stamp, _, payload = heapq.heappop(self.pending)
            if best is not None and best[0] > stamp:
                self.overtaken += 1
                continue
            if best is not None:
                self.overtaken += 1
            best = (stamp, payload)
        if best is None or (self.last_ns is not None and best[0] <= self.last_ns):
            if best is not None:
                self.overtaken += 1
            return None
        self.last_ns = best[0]
        self.delivered += 1
        return best

    def counts(self) -> dict[str, int]:
        """What became of the states sent."""
        return {
            "sent": self.sent,
            "delivered": self.delivered,
            "lost": self.lost,
            "withheld": self.withheld,
            "overtaken": self.overtaken,
        }
