"""The guidance's mutable state: one record that its step reads and writes.

:class:`~attitude_core.fsw.guidance.guidance.Guidance` keeps what its per-state step
changes in a :class:`GuidanceState` (``guidance.state``); its attributes of the same
names (``status``, ``t_prev``, ``_since_progress``, ...) are the record's fields
(:class:`~attitude_core.fsw.guidance.state_field.StateField`). Its Python step
(``Guidance.update_reference``) and the compiled one (``_kernels.GuidanceCore``,
``kernels/guidance.pxi``) both step this record: with the compiled kernels built the
guidance holds the compiled twin (``_kernels.GuidanceState``, C fields of the same names,
meanings and defaults). The planner's own state is its
:class:`~attitude_core.fsw.guidance.fepf_state.FepfState`.

The fields:

* ``status``: the guidance's status, judged on the body;
* ``t_prev``: the previous state's time, s (None before the first);
* ``omega_prev``: the target body rate published last, rad/s, a float array (3,);
* the tracking governor's derating: ``derating`` (share of the declared acceleration
  the plant has shown), ``derated_at`` (state time of the last halving),
  ``behind_since`` (state time since which the governor has held, or None);
* progress: ``since_progress`` (s), ``best_body`` (rad), ``best_target`` (MRP);
* the route: ``pending`` (a route being planned off the step path, a future, or None)
  and ``follower`` (the :class:`RouteFollower` flying the route, or None).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["GuidanceState"]


class GuidanceState:
    """The guidance's mutable state (the module docstring), with its defaults; the
    guidance sets its start."""

    __slots__ = (
        "t_prev",
        "omega_prev",
        "status",
        "behind_since",
        "pending",
        "follower",
        "derating",
        "derated_at",
        "since_progress",
        "best_body",
        "best_target",
    )

    def __init__(self) -> None:
        self.t_prev: float | None = None
        self.omega_prev = np.zeros(3)
        self.status: Any = None  # a PlannerStatus once the guidance starts
        self.behind_since: float | None = None
        self.pending: Any = None  # Future[Route] | None
        self.follower: Any = None  # RouteFollower | None
        self.derating = 1.0
        self.derated_at = -math.inf
        self.since_progress = 0.0
        self.best_body = math.inf
        self.best_target = math.inf
