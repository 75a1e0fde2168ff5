"""The fault vocabulary: what ``summary.json`` ``faults``, ``/diagnostics`` and the
report call a fault, defined once (:class:`FaultKind`, :class:`Fault`).

A fault has a kind, a start and an end (seconds since the run's first state; the end
None while it lasts, or when the run ended in it) and a sentence of detail.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from attitude_core.contract.diagnostics import PlannerDiagnostics
from attitude_core.contract.status import DiagnosticLevel, PlannerStatus

__all__ = ["FaultKind", "Fault", "FAULT_DIAGNOSTIC_NAME", "reported_status"]

FAULT_DIAGNOSTIC_NAME = "fdir"
"""Prefix of the ``/diagnostics`` status names of faults: ``fdir/<kind>``."""


class FaultKind(enum.StrEnum):
    """A fault's kind; ``level`` is its ``/diagnostics`` level while it lasts."""

    level: DiagnosticLevel

    def __new__(cls, value: str, level: DiagnosticLevel) -> FaultKind:
        member = str.__new__(cls, value)
        member._value_ = value
        member.level = level
        return member

    @property
    def diagnostic_name(self) -> str:
        """The ``/diagnostics`` status name of this kind's faults: ``fdir/<kind>``."""
        return f"{FAULT_DIAGNOSTIC_NAME}/{self.value}"

    @classmethod
    def parse(cls, text: str) -> FaultKind:
        """The kind whose value is ``text`` (ValueError if none)."""
        for kind in cls:
            if kind.value == text:
                return kind
        raise ValueError(f"{text!r} is not a fault kind {[k.value for k in cls]}")

    STATE_LOST = ("state_lost", DiagnosticLevel.WARN)
    """No measured state newer than ``fdir.state_timeout_s``: the loop flew on the
    predicted state (braked after ``fdir.predict_s``)."""
    STAR_TRACKER_OUTAGE = ("star_tracker_outage", DiagnosticLevel.WARN)
    """No star tracker solution (a scheduled outage, the body rate above the tracker's
    limit, or a bright object in its exclusion zone): the estimate ran on the gyro."""
    SAFE_MODE = ("safe_mode", DiagnosticLevel.ERROR)
    """No measured state for ``fdir.safe_after_s``: zero torque; the run ends."""


@dataclass(frozen=True)
class Fault:
    """One fault: ``t_start_s`` to ``t_end_s`` (None: to the run's end)."""

    kind: FaultKind
    t_start_s: float
    t_end_s: float | None
    detail: str

    def to_json(self) -> dict[str, Any]:
        """The ``summary.json`` entry ``{kind, t_start_s, t_end_s, detail}``."""
        return {
            "kind": self.kind.value,
            "t_start_s": round(self.t_start_s, 9),
            "t_end_s": None if self.t_end_s is None else round(self.t_end_s, 9),
            "detail": self.detail,
        }

    @property
    def diagnostic_name(self) -> str:
        """Its ``/diagnostics`` status name: ``fdir/<kind>``."""
        return self.kind.diagnostic_name

    @property
    def diagnostic_level(self) -> DiagnosticLevel:
        """Its kind's level while it lasts, OK once it has ended."""
        return self.kind.level if self.t_end_s is None else DiagnosticLevel.OK

    def diagnostic_values(self) -> list[tuple[str, str]]:
        """Its ``/diagnostics`` key/values."""
        end = "" if self.t_end_s is None else f"{self.t_end_s:.9g}"
        return [("kind", self.kind.value), ("t_start_s", f"{self.t_start_s:.9g}"), ("t_end_s", end)]

    @classmethod
    def from_json(cls, entry: dict[str, Any]) -> Fault:
        end = entry.get("t_end_s")
        return cls(
            FaultKind.parse(str(entry["kind"])),
            float(entry["t_start_s"]),
            None if end is None else float(end),
            str(entry["detail"]),
        )


def reported_status(name: str, level: int, values: dict[str, str]) -> PlannerStatus | None:
    """The planner status one ``/diagnostics`` status reports: the planner's per-step
    report's, or ``safe_mode`` for the start of a ``fdir/safe_mode`` fault (in safe mode
    no state comes, so no per-step report); None for any other status."""
    if name == FaultKind.SAFE_MODE.diagnostic_name:
        return PlannerStatus.SAFE_MODE if level != DiagnosticLevel.OK else None
    try:
        return PlannerDiagnostics.from_values(values).status
    except ValueError:  # another node's diagnostics
        return None
