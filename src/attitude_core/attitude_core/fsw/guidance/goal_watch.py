"""When the moving sky covers the goal: the windows in which the goal attitude lacks its
clearance, predicted from the sky (deterministic: ephemerides, orbit, constant rates).

Inputs: a :class:`~attitude_core.models.sky.Sky`, the goal ``sigma_DN``, a time span, the
clearance the goal must keep (the planner's buffer) and the constraints' names. Outputs:
:class:`Blockage` windows, each with the constraint that first takes the clearance away
and the goal's true margin in it (when the keep-out reaches the goal, the least margin);
:func:`goal_margin_bounds_deg`, the goal's least and greatest margin over a span (what
the buffer rule, :func:`attitude_core.assembly.guidance.buffer_deg`, caps the clearance
with).

The goal's exact margins are sampled every :data:`SCAN_STEP_S`; between two samples a
margin changes by at most the object's rate bound times the spacing, so a sample counts
as blocked when its margin is below the clearance plus half that change: no blockage
between samples is missed. For the same reason a margin's lower bound between samples is
the sample less half that change: a goal whose lower bound stays positive over a span is
never covered in it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import Vec3Like
from attitude_core.models.sky import Sky

__all__ = [
    "SCAN_STEP_S",
    "Blockage",
    "goal_blockages",
    "goal_margin_bounds_deg",
    "safe_until_s",
]

SCAN_STEP_S = 1.0
"""Spacing of the goal's margin samples, s."""


@dataclass(frozen=True)
class Blockage:
    """The goal lacks its clearance from ``start_s`` to ``end_s`` (s after the epoch;
    ``end_s`` is None when it has not cleared by the end of the span scanned)."""

    constraint: str  # "<instrument>/<object>" or "keep_in/<name>"
    start_s: float
    end_s: float | None
    clearance_deg: float
    least_margin_deg: float = math.nan  # the goal's least sampled margin in the window
    t_least_s: float = math.nan  # ... and when
    t_covered_s: float | None = None  # the first sample with the goal inside (margin <= 0)

    def covers(self, t_s: float) -> bool:
        return self.start_s <= t_s and (self.end_s is None or t_s < self.end_s)

    def reason(self) -> str:
        until = "the end of the run" if self.end_s is None else f"{self.end_s:.1f} s"
        if self.t_covered_s is not None:
            what = f"the keep-out reaches the goal at {self.t_covered_s:.1f} s"
            if self.constraint.startswith("keep_in/"):
                what = f"the goal leaves the keep-in cone at {self.t_covered_s:.1f} s"
        else:
            what = f"its margin falls to {self.least_margin_deg:.2f} deg at {self.t_least_s:.1f} s"
        return (
            f"goal blocked by {self.constraint}: {what} (below the "
            f"{self.clearance_deg:.2f} deg clearance from {self.start_s:.1f} s to {until})"
        )


def _margin_rate_bounds_deg_s(sky: Sky) -> npt.NDArray[np.float64]:
    """A bound on each constraint margin's rate, deg/s, in the order of
    :meth:`Sky.constraint_margins_deg` (keep-out pairs by their object, then keep-in)."""
    return np.concatenate([sky.rate_bounds_deg_s[sky.pair_object], sky.keep_in_rate_bounds_deg_s])


def goal_blockages(
    sky: Sky,
    goal: Vec3Like,
    t0_s: float,
    t1_s: float,
    clearance_deg: float,
    names: Sequence[str],
    step_s: float = SCAN_STEP_S,
) -> list[Blockage]:
    """The windows in ``[t0_s, t1_s]`` in which the goal's margin falls below
    ``clearance_deg``, in time order (module docstring)."""
    if sky.static or t1_s < t0_s:
        return []
    t = np.arange(t0_s, t1_s + step_s, step_s)
    margins = sky.constraint_margins_deg(t, np.broadcast_to(np.asarray(goal, float), (len(t), 3)))
    rates = _margin_rate_bounds_deg_s(sky)
    short = margins < clearance_deg + 0.5 * step_s * rates[None, :]
    blocked: npt.NDArray[np.bool_] = np.asarray(short.any(axis=1))
    out: list[Blockage] = []
    k = 0
    while k < len(t):
        if not blocked[k]:
            k += 1
            continue
        first = k
        while k < len(t) and blocked[k]:
            k += 1
        c = int(np.argmin(margins[first] - clearance_deg))
        start = max(float(t[first]) - step_s, t0_s) if first > 0 else float(t[0])
        end = float(t[k]) if k < len(t) else None
        window = margins[first:k, c]
        inside = np.flatnonzero(window <= 0.0)
        least = int(np.argmin(window))
        out.append(
            Blockage(
                names[c],
                start,
                end,
                clearance_deg,
                float(window[least]),
                float(t[first + least]),
                float(t[first + inside[0]]) if len(inside) else None,
            )
        )
    return out


def goal_margin_bounds_deg(
    sky: Sky, goal: Vec3Like, t0_s: float, t1_s: float, step_s: float = SCAN_STEP_S
) -> tuple[float, float]:
    """The goal's least and greatest margin over ``[t0_s, t1_s]``, deg, each a lower
    bound at every instant (a sample less half the largest change to the next, module
    docstring): a positive least margin means the sky never covers the goal in the span.
    A static sky: the margin at ``t0_s``, twice."""
    g = np.asarray(goal, dtype=float)
    if sky.static or t1_s <= t0_s:
        m = float(np.min(sky.constraint_margins_deg(t0_s, g)))
        return m, m
    t = np.append(np.arange(t0_s, t1_s, step_s), t1_s)
    margins = sky.constraint_margins_deg(t, np.broadcast_to(g, (len(t), 3)))
    rates = _margin_rate_bounds_deg_s(sky)
    low = (margins - 0.5 * step_s * rates[None, :]).min(axis=1)
    return float(low.min()), float(low.max())


def safe_until_s(blockages: Sequence[Blockage], t_s: float) -> float:
    """When the goal next loses its clearance after ``t_s`` (``inf``: not within the
    span scanned; ``t_s`` itself when it lacks it now)."""
    for b in blockages:
        if b.covers(t_s):
            return t_s
        if b.start_s > t_s:
            return b.start_s
    return math.inf
