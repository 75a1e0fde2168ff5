"""Keep-in cones as parameters: the optional ``keep_in`` group of the scenario's rows,
its bounds in the loader, and its declaration by the nodes (:mod:`attitude_ros.params`
on a stand-in for rclpy's Node)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from parameter_rows import (
    CASE1,
    CASE1_ROWS,
    ROOT,
    inside_values,
    refused_just_outside,
    row,
    with_value,
)

from attitude_core.config.node_parameters import CONTROLLER, PLANNER, RECORDER, SIMULATOR
from attitude_core.config.parameters import NodeParameterError
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_flatten import scenario_keys
from attitude_core.config.scenario_loader import loads_scenario

# --- keep-in cones: the optional group --------------------------------------------------

KEEP_IN_FILE = ROOT / "scenarios" / "keep_in.yaml"
KEEP_IN = KEEP_IN_FILE.read_text(encoding="utf-8")
KEEP_IN_ROWS = scenario_keys(
    ("star_tracker",), ("object_1", "object_2", "object_3", "sun"), ("sun_sensor",)
)
KEEP_IN_BOUNDED = [q for q in KEEP_IN_ROWS if q.key.startswith("keep_in.") and q.bounds]


def test_keep_in_rows_are_table_rows_like_the_instruments():
    names = row("keep_in.names", KEEP_IN_ROWS)
    assert (names.kind, names.ros_type, names.default, names.required) == (
        "names",
        "string_array",
        None,
        False,
    )
    assert row("instruments.names", KEEP_IN_ROWS).required  # the others stay required
    assert row("bright_objects.names", KEEP_IN_ROWS).required
    per_name = {q.key: q for q in KEEP_IN_ROWS if q.key.startswith("keep_in.sun_sensor.")}
    assert {k: (q.kind, q.required) for k, q in per_name.items()} == {
        "keep_in.sun_sensor.axis_body": ("unit3", True),
        # One of the two (checked by the loader): a fixed direction or a body's centre.
        "keep_in.sun_sensor.direction_inertial": ("unit3", False),
        "keep_in.sun_sensor.ephemeris": ("str", False),
        "keep_in.sun_sensor.max_angle_deg": ("float", True),
    }
    angle = per_name["keep_in.sun_sensor.max_angle_deg"]
    assert angle.rule == "(0, 180)" and angle.bounds.closed() == (0.0, 180.0)
    assert len(KEEP_IN_ROWS) == len({q.key for q in KEEP_IN_ROWS})
    # Without keep-in names there are no per-cone rows, only the optional list.
    assert [q.key for q in CASE1_ROWS if q.key.startswith("keep_in.")] == ["keep_in.names"]


def test_keep_in_file_loads_unedited():
    sc = loads_scenario(KEEP_IN)
    assert sc.keep_in_names == ("sun_sensor",) and sc.keep_in_max_angles_deg.tolist() == [70.0]


@pytest.mark.parametrize("param", KEEP_IN_BOUNDED, ids=lambda q: q.key)
def test_loader_refuses_a_keep_in_value_just_outside_the_bound(param):
    refused_just_outside(KEEP_IN, "keep_in.yaml", param)


@pytest.mark.parametrize("param", KEEP_IN_BOUNDED, ids=lambda q: q.key)
def test_loader_does_not_refuse_the_keep_in_key_just_inside_the_bound(param):
    for value in inside_values(param):
        try:
            loads_scenario(with_value(KEEP_IN, param.key, value))
        except ScenarioError as exc:  # a cone of 5e-324 deg: the start is outside it
            assert exc.key == "initial_mrp" and "keep_in.sun_sensor" in exc.reason, str(exc)


def test_the_planner_reads_the_keep_in_cones_and_the_others_do_not():
    assert PLANNER.reads_scenario_key("keep_in.names")
    assert PLANNER.reads_scenario_key("keep_in.sun_sensor.max_angle_deg")
    for table in (CONTROLLER, SIMULATOR, RECORDER):
        assert not table.reads_scenario_key("keep_in.names")
        assert not table.reads_scenario_key("keep_in.sun_sensor.axis_body")


# The ROS declaration path (attitude_ros.params) on a stand-in for rclpy's Node: its
# parameter API as rclpy implements it (overrides from --params-file / -p; a row declared
# with a type and no override is unset; an override of another type is refused). The
# real nodes are declared over DDS in ros/test_node_parameters.py.


class StandInNode:
    def __init__(self, overrides: dict) -> None:
        from rclpy.parameter import Parameter

        self._parameter_overrides = {k: Parameter(k, value=v) for k, v in overrides.items()}
        self.declared: dict = {}  # name -> (value or None, descriptor)

    def get_fully_qualified_name(self) -> str:
        return "/stand_in"

    def declare_parameter(self, name, value, descriptor):
        from rclpy.exceptions import InvalidParameterTypeException
        from rclpy.parameter import Parameter

        declared_type = value if isinstance(value, Parameter.Type) else None
        if name in self._parameter_overrides:
            given = self._parameter_overrides[name]
            if declared_type is not None and given.type_ != declared_type:
                raise InvalidParameterTypeException(given, declared_type)
            value = given.value
        elif declared_type is not None:
            value = None  # declared typed and unset
        self.declared[name] = (value, descriptor)

    def get_parameter(self, name):
        from rclpy.exceptions import ParameterUninitializedException

        value = self.declared[name][0]
        if value is None:
            raise ParameterUninitializedException(name)
        return type("Value", (), {"value": value})()

    def has_parameter(self, name) -> bool:
        return name in self.declared


def _file_overrides(text: str) -> dict:
    from attitude_core.config.scenario_flatten import flatten_parameters

    return flatten_parameters(yaml.safe_load(text)["/**"]["ros__parameters"])


def test_planner_declares_the_keep_in_rows_and_builds_the_loader_scenario():
    from rcl_interfaces.msg import ParameterType

    from attitude_ros.params import declare_node_parameters

    node = StandInNode(_file_overrides(KEEP_IN))
    _, sc = declare_node_parameters(node, PLANNER)
    expected = loads_scenario(KEEP_IN)
    assert sc.keep_in_names == expected.keep_in_names == ("sun_sensor",)
    for name in ("keep_in_axes_body", "keep_in_directions_inertial", "keep_in_max_angles_deg"):
        np.testing.assert_array_equal(getattr(sc, name), getattr(expected, name), err_msg=name)
    assert sc.constraint_names == expected.constraint_names
    types = {k: d.type for k, (_, d) in node.declared.items()}
    assert types["keep_in.names"] == ParameterType.PARAMETER_STRING_ARRAY
    assert types["keep_in.sun_sensor.axis_body"] == ParameterType.PARAMETER_DOUBLE_ARRAY
    assert types["keep_in.sun_sensor.max_angle_deg"] == ParameterType.PARAMETER_DOUBLE
    angle = node.declared["keep_in.sun_sensor.max_angle_deg"][1]
    assert "(0, 180)" in angle.description
    assert [(r.from_value, r.to_value) for r in angle.floating_point_range] == [(0.0, 180.0)]


def test_without_keep_in_the_planner_declares_the_list_unset():
    from attitude_ros.params import declare_node_parameters

    node = StandInNode(_file_overrides(CASE1))
    _, sc = declare_node_parameters(node, PLANNER)
    assert node.has_parameter("keep_in.names")  # declared, typed, unset
    assert node.declared["keep_in.names"][0] is None
    assert not any(k.startswith("keep_in.") and k != "keep_in.names" for k in node.declared)
    assert sc.keep_in_names == () and sc.keep_in_axes_body.shape == (0, 3)


@pytest.mark.parametrize("table", [CONTROLLER, SIMULATOR], ids=["controller", "simulator"])
def test_nodes_that_do_not_read_keep_in_still_validate_it(table):
    from attitude_ros.params import declare_node_parameters

    node = StandInNode(_file_overrides(KEEP_IN))
    _, sc = declare_node_parameters(node, table)
    assert not any(k.startswith("keep_in.") for k in node.declared)
    assert sc.keep_in_names == ("sun_sensor",)  # from the parameters it did not declare
    bad = _file_overrides(with_value(KEEP_IN, "keep_in.sun_sensor.max_angle_deg", 190.0))
    with pytest.raises(ScenarioError) as info:
        declare_node_parameters(StandInNode(bad), table)
    assert info.value.key == "keep_in.sun_sensor.max_angle_deg"
    assert info.value.reason == "must be in (0, 180), got 190.0"


def test_the_recorder_takes_a_shared_file_with_keep_in_cones():
    from attitude_ros.params import declare_node_parameters

    overrides = _file_overrides(KEEP_IN)
    overrides["output_dir"] = "bag"
    own, sc = declare_node_parameters(StandInNode(overrides), RECORDER)
    assert sc is None and own.output_dir == "bag"
    overrides["keep_inn.names"] = ["sun_sensor"]  # not a scenario group: a typo, refused
    with pytest.raises(NodeParameterError) as info:
        declare_node_parameters(StandInNode(overrides), RECORDER)
    assert info.value.key == "keep_inn.names"
