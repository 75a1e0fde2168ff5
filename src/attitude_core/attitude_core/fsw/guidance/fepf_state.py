"""The FEPF planner's mutable state: one record that its step reads and writes.

:class:`~attitude_core.fsw.guidance.fepf.FepfPlanner` keeps everything that changes from
step to step in a :class:`FepfState` (``planner.state``); the rest (geometry,
configuration, FIS) is fixed, or handed over when it changes. Its Python step (the
``*_reference`` methods) and the compiled one (``_kernels.FepfCore``,
``kernels/fepf.pxi``) both step this record, field by field the same: with the compiled
kernels built the planner holds the compiled twin (``_kernels.FepfState``, C fields of
the same names, meanings and defaults), which the Python step reads and writes as it
does this one, so the two can take turns on one planner.

Vectors are tuples of 3 floats (never None). The fields:

* the target: ``sigma_t`` (``sigma_BN``, ``|sigma| <= 1``) and ``status``;
* the goal (:meth:`FepfPlanner.set_goal`): ``goal``, ``final_goal`` (False at a route's
  intermediate waypoint), ``beyond_mrp`` (the route's length after it);
* the rate held until the next proposal: ``rate`` (MRP rate, 1/s), ``omega_held`` (its
  body rate where it was set, eq. 12), ``checked`` (``(rate, dt)`` of the step already
  made safe, or None);
* the last proposal's: ``d_goal`` (MRP distance to the goal, planning frame),
  ``raw_speed`` (its speed before the step's shortening), ``last_obstacle_distance`` and
  ``last_obstacle_direction`` (``sigma_BN`` space), ``goal_in_sight``, ``wanted_omega``
  (the law's rate before shaping, as a body rate);
* the stuck watchdog: ``best_goal_distance``, ``since_progress`` (s);
* ``evade``: a moving sky's cone coming over a held target pushes it out;
* memos of pure functions of the target (cleared with the geometry): ``margin`` at
  ``margin_at`` (:meth:`FepfPlanner.margin_deg`), ``arc`` for ``arc_key`` (the target
  and the end, :meth:`FepfPlanner.arc_margin_deg`); None: nothing kept.
"""

from __future__ import annotations

import math
from typing import Any

from attitude_core.models.mrp import Vec3

__all__ = ["FepfState"]

_ZERO: Vec3 = (0.0, 0.0, 0.0)


class FepfState:
    """The planner's mutable state (the module docstring), with its defaults; the
    planner's ``reset`` sets the start."""

    __slots__ = (
        "sigma_t",
        "goal",
        "rate",
        "omega_held",
        "last_obstacle_direction",
        "wanted_omega",
        "status",
        "checked",
        "margin_at",
        "arc_key",
        "final_goal",
        "goal_in_sight",
        "evade",
        "beyond_mrp",
        "d_goal",
        "raw_speed",
        "last_obstacle_distance",
        "best_goal_distance",
        "since_progress",
        "margin",
        "arc",
    )

    def __init__(self) -> None:
        self.sigma_t: Vec3 = _ZERO
        self.goal: Vec3 = _ZERO
        self.rate: Vec3 = _ZERO
        self.omega_held: Vec3 = _ZERO
        self.last_obstacle_direction: Vec3 = _ZERO
        self.wanted_omega: Vec3 = _ZERO
        self.status: Any = None  # a PlannerStatus once the planner starts
        self.checked: tuple[Vec3, float] | None = None
        self.margin_at: Vec3 | None = None
        self.arc_key: tuple[Vec3, Vec3] | None = None
        self.final_goal = True
        self.goal_in_sight = False
        self.evade = False
        self.beyond_mrp = 0.0
        self.d_goal = math.inf
        self.raw_speed = 0.0
        self.last_obstacle_distance = math.nan
        self.best_goal_distance = math.inf
        self.since_progress = 0.0
        self.margin = math.nan
        self.arc = math.nan
