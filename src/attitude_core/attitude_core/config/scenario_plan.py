"""The scenario's observation plan (``plan.*``) checked and built.

``plan.names`` lists the targets in the order they are flown; each has its
``desired_mrp`` and ``dwell_s``. A scenario with a plan has no top-level
``desired_mrp`` (its guidance starts with the plan's first target). A target is not
judged on load: one that would put an instrument inside a keep-out, or that no route
reaches, is refused (or infeasible) when it comes up, recorded and skipped
(:mod:`attitude_core.assembly.goal_sequence`). Plans are flown with the ideal torque (or
``actuators.*``), with or without sensors; not yet with wheels or a link.
"""

from typing import Any

import numpy as np

from attitude_core.config.scenario import PlanTarget, ScenarioError, frozen_array
from attitude_core.models.link_spec import LinkSpec
from attitude_core.models.mrp import to_principal
from attitude_core.models.wheel_array import WheelArray

__all__ = ["parse_plan"]


def parse_plan(
    names: tuple[str, ...],
    rows: list[dict[str, Any]],
    values: dict[str, Any],
    source: str,
    wheels: WheelArray | None,
    link: LinkSpec | None,
) -> tuple[PlanTarget, ...]:
    """The plan's targets in order (empty without ``plan.names``); ``desired_mrp`` is
    required without one and refused with one."""
    if not names:
        if values["desired_mrp"] is None:
            raise ScenarioError(source, "desired_mrp", "missing required key (or plan.*)")
        return ()
    if values["desired_mrp"] is not None:
        raise ScenarioError(
            source,
            "desired_mrp",
            "a scenario with plan.* has no top-level desired_mrp: the goals are the plan's "
            "targets (plan.<name>.desired_mrp); remove one of the two",
        )
    for key, what in (("wheels", wheels), ("link", link)):
        if what is not None:
            raise ScenarioError(source, "plan.names", f"a plan with {key}.* is not supported yet")
    return tuple(
        PlanTarget(
            name,
            frozen_array(to_principal(np.asarray(d["desired_mrp"], dtype=float))),
            float(d["dwell_s"]),
        )
        for name, d in zip(names, rows, strict=True)
    )
