"""A run's margin (deg) against time for one constraint (in: a run and a keep-out
``Pair`` or ``KeepIn`` cone; out: the series, or None when the run lacks the
constraint), and the index of a run's keep-in cone. No plotting here."""

from __future__ import annotations

import numpy as np

from ..data import ReportRun
from ..geometry import KeepIn, Pair
from ..sky import constraint_margins_deg, pair_margins_deg
from .context import Floats

__all__ = ["keep_in_index", "run_keep_in_margins", "run_margins"]


def keep_in_index(run: ReportRun, cone: KeepIn) -> int | None:
    """Index of the run's keep-in cone equal to ``cone`` (None: the run has none)."""
    sc = run.scenario
    for k, name in enumerate(sc.keep_in_names):
        if (
            name == cone.name
            and np.allclose(sc.keep_in_axes_body[k], cone.axis_body)
            and np.allclose(sc.keep_in_directions_inertial[k], cone.direction_inertial)
            and abs(float(sc.keep_in_max_angles_deg[k]) - cone.max_angle_deg) < 1e-9
        ):
            return k
    return None


def run_keep_in_margins(run: ReportRun, cone: KeepIn) -> Floats | None:
    """Margin (deg) against time of the run's keep-in cone equal to ``cone``."""
    k = keep_in_index(run, cone)
    if k is None:
        return None
    return constraint_margins_deg(run)[:, len(run.scenario.sky.pair_exclusion_deg) + k]


def run_margins(run: ReportRun, constraint: Pair | KeepIn) -> Floats | None:
    if isinstance(constraint, KeepIn):
        return run_keep_in_margins(run, constraint)
    return pair_margins_deg(run, constraint)
