"""The state watchdog: how old the newest measured state is, and what that means.

One module for the planner and the controller (and the record's replay of a run's
stamps, :func:`faults_from_stamps`). Input: each measured state's stamp (ns) and the
stack's clock (ns: wall time in real time, ``/clock`` in lockstep). Output: the mode
(:class:`FdirMode`) and the faults (:class:`attitude_core.contract.faults.Fault`):

* age ``<= fdir.state_timeout_s``: ``nominal``, the loop answers states;
* older: ``predicting`` (a ``state_lost`` fault from the newest stamp plus the timeout),
  flown on the predicted state;
* older than ``fdir.predict_s``: ``braking`` (the controller brakes the predicted rate,
  then commands zero torque);
* older than ``fdir.safe_after_s``: ``safe_mode`` (a ``safe_mode`` fault), latched: zero
  torque from then on, whatever comes.

A state that comes back ends the ``state_lost`` fault at its stamp. Fault times are
seconds since the first state's stamp (the guidance's ``t = 0``).
"""

from __future__ import annotations

import enum

from attitude_core.contract.faults import Fault, FaultKind
from attitude_core.fsw.fdir.fdir_config import NS_PER_S, FdirConfig

__all__ = ["FdirMode", "StateWatchdog", "faults_from_stamps"]


class FdirMode(enum.StrEnum):
    NOMINAL = "nominal"
    PREDICTING = "predicting"
    BRAKING = "braking"
    SAFE_MODE = "safe_mode"


class StateWatchdog:
    """See the module docstring."""

    def __init__(self, config: FdirConfig, origin_ns: int | None = None) -> None:
        self.config = config
        self.first_ns: int | None = origin_ns  # t = 0 of the fault times (default: the
        # first state's time)
        self.last_ns: int | None = None  # stamp of the newest measured state
        self.safe = False
        self.faults: list[Fault] = []  # closed faults, in order
        self.lost_since_ns: int | None = None  # open state_lost fault: its start
        self.safe_since_ns: int | None = None

    def seconds(self, t_ns: int) -> float:
        return (t_ns - (self.first_ns or 0)) / NS_PER_S

    def measured(self, stamp_ns: int, now_ns: int | None = None) -> list[Fault]:
        """A measured state stamped ``stamp_ns``, received at ``now_ns`` (default: its
        stamp); returns the fault it ends (if any), ended at its receipt."""
        if self.first_ns is None:
            self.first_ns = stamp_ns
        closed: list[Fault] = []
        if self.last_ns is not None and stamp_ns <= self.last_ns:
            return closed
        gap = self.last_ns is not None and self.config.stale(stamp_ns - self.last_ns)
        if gap and self.lost_since_ns is None:  # not ticked in between: the gap counts
            self.lost_since_ns = self.last_ns + self.config.timeout_ns  # type: ignore[operator]
        if self.lost_since_ns is not None:
            closed.append(self._close_lost(stamp_ns, stamp_ns if now_ns is None else now_ns))
        self.last_ns = stamp_ns
        return closed

    def mode(self, now_ns: int) -> FdirMode:
        """The mode at ``now_ns`` (``nominal`` before the first state)."""
        if self.safe:
            return FdirMode.SAFE_MODE
        if self.last_ns is None:
            return FdirMode.NOMINAL
        age = now_ns - self.last_ns
        cfg = self.config
        if age > cfg.safe_ns:
            return FdirMode.SAFE_MODE
        if age > cfg.predict_ns:
            return FdirMode.BRAKING
        return FdirMode.PREDICTING if cfg.stale(age) else FdirMode.NOMINAL

    def check(self, now_ns: int) -> tuple[FdirMode, list[Fault]]:
        """The mode at ``now_ns`` and the faults it opens (``end`` None), once each."""
        mode = self.mode(now_ns)
        opened: list[Fault] = []
        if mode is not FdirMode.NOMINAL and self.last_ns is not None:
            if self.lost_since_ns is None and not self.safe:
                self.lost_since_ns = self.last_ns + self.config.timeout_ns
                opened.append(self.open_lost())
            if mode is FdirMode.SAFE_MODE and not self.safe:
                self.safe = True
                self.safe_since_ns = self.last_ns + self.config.safe_ns
                opened.append(self.open_safe())
        return mode, opened

    def open_lost(self) -> Fault:
        assert self.lost_since_ns is not None and self.last_ns is not None
        return Fault(
            FaultKind.STATE_LOST,
            self.seconds(self.lost_since_ns),
            None,
            f"no measured state after the one stamped {self.seconds(self.last_ns):.3f} s: "
            "flying on the predicted state",
        )

    def open_safe(self) -> Fault:
        assert self.safe_since_ns is not None and self.last_ns is not None
        return Fault(
            FaultKind.SAFE_MODE,
            self.seconds(self.safe_since_ns),
            None,
            f"no measured state for {self.config.safe_after_s:g} s after the one stamped "
            f"{self.seconds(self.last_ns):.3f} s: safe mode, zero torque",
        )

    def _close_lost(self, stamp_ns: int, now_ns: int) -> Fault:
        assert self.lost_since_ns is not None and self.last_ns is not None
        end_ns = max(now_ns, self.lost_since_ns)
        gap = (end_ns - self.last_ns) / NS_PER_S
        how = "predicted" if gap <= self.config.predict_s else "predicted, then braked"
        fault = Fault(
            FaultKind.STATE_LOST,
            self.seconds(self.lost_since_ns),
            self.seconds(end_ns),
            f"no fresh measured state for {gap:.3f} s after the one stamped "
            f"{self.seconds(self.last_ns):.3f} s ({how}); the state stamped "
            f"{self.seconds(stamp_ns):.3f} s came at {self.seconds(end_ns):.3f} s",
        )
        self.faults.append(fault)
        self.lost_since_ns = None
        return fault

    def all_faults(self) -> list[Fault]:
        """Every fault so far, in order of start; those still open with no end."""
        out = list(self.faults)
        if self.lost_since_ns is not None:
            out.append(self.open_lost())
        if self.safe:
            out.append(self.open_safe())
        return sorted(out, key=lambda f: f.t_start_s)


def faults_from_stamps(
    config: FdirConfig, stamps_ns: list[int], end_ns: int, origin_ns: int | None = None
) -> list[Fault]:
    """The faults of a run whose measured states had these stamps (increasing) and
    whose clock ran to ``end_ns`` (times from ``origin_ns``, default the first stamp):
    the watchdog replayed on the record."""
    dog = StateWatchdog(config, origin_ns)
    for stamp in stamps_ns:
        dog.check(stamp)  # a gap long enough latches safe mode, as it did in the run
        dog.measured(stamp)
    dog.check(end_ns)
    return dog.all_faults()
