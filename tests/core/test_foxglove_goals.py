"""The Foxglove layout's goal panels (docs/foxglove_layout.json): each goal report's
outcome, the commanded goals and the goal in force."""

from __future__ import annotations

from test_foxglove_layout import layout, scripts  # noqa: F401 - the fixtures

from attitude_core.contract import topics
from attitude_core.contract.goals import GOAL_DIAGNOSTIC_NAME
from attitude_core.contract.status import GoalOutcome


def test_goal_panels_show_each_outcome_the_commands_and_the_goal_in_force(layout, scripts):  # noqa: F811
    """The goals timeline shows each goal report's outcome (every GoalOutcome, by its
    value), the raw panel the commanded goals (/planner/goal), and the MRP plot the goal
    in force from the user script that reads the reports' sigma_goal."""
    config = layout["configById"]["StateTransitions!goals"]
    (path,) = config["paths"]
    assert path["value"] == (
        f'{topics.DIAGNOSTICS}.status[:]{{name=="{GOAL_DIAGNOSTIC_NAME}"}}'
        '.values[:]{key=="outcome"}.value'
    )
    assert {st["value"] for st in path["customStates"]["states"]} == {o.value for o in GoalOutcome}
    assert layout["configById"]["RawMessages!goal_commands"]["topicPath"] == topics.GOAL
    script = scripts["/studio_script/goal_mrp"]
    assert script.inputs == [topics.DIAGNOSTICS]
    assert '"sigma_goal"' in script.source and f'"{GOAL_DIAGNOSTIC_NAME}"' in script.source
    values = {p["value"] for p in layout["configById"]["Plot!attitude_mrp"]["paths"]}
    assert {f"/studio_script/goal_mrp.vector.{a}" for a in "xyz"} <= values
