"""A live progress line (counts by outcome, rate, ETA) on a terminal; silent otherwise."""

from __future__ import annotations

import collections
import time
from typing import TextIO

from .task import OUTCOMES

__all__ = ["Progress"]


def _duration(s: float) -> str:
    s = int(round(s))
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


class Progress:
    def __init__(self, total: int, already: int, stream: TextIO, width: int = 28) -> None:
        self.total, self.done, self.new = total, already, 0
        self.stream, self.width = stream, width
        self.live = stream.isatty()
        self.counts: collections.Counter[str] = collections.Counter()
        self.t0 = time.monotonic()
        self._drawn = 0.0

    def update(self, outcome: str) -> None:
        self.done += 1
        self.new += 1
        self.counts[outcome] += 1
        now = time.monotonic()
        if self.live and (now - self._drawn > 0.1 or self.done == self.total):
            self._drawn = now
            self.stream.write("\r" + self.line(now) + "\x1b[K")
            self.stream.flush()

    def line(self, now: float | None = None) -> str:
        now = time.monotonic() if now is None else now
        elapsed = now - self.t0
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * int(frac * self.width)
        rate = self.new / elapsed if elapsed > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        counts = " ".join(f"{name} {self.counts[name]}" for name in OUTCOMES if self.counts[name])
        eta_text = _duration(eta) if eta != float("inf") else "?"
        return (
            f"[{bar:<{self.width}}] {self.done}/{self.total} {counts}  {rate:.1f}/s  ETA {eta_text}"
        )

    def close(self) -> None:
        if self.live:
            self.stream.write("\n")
            self.stream.flush()
