"""In-process tests of the node shells' parameters: the scenario keys each node
declares, its own rows, and the bad values it refuses (see ``shells.py``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter
from shells import CASE1, ROOT

from attitude_bringup.recorder_node import BagRecorderNode
from attitude_controller.controller_node import PdControllerNode
from attitude_core.config import node_graph
from attitude_core.config.parameters import NodeParameterError
from attitude_core.config.scenario import Scenario, ScenarioError
from attitude_core.config.scenario_flatten import scenario_keys
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_planner.planner_node import FepfPlannerNode
from attitude_tools.bag.run_record import scenario_from_bag
from spacecraft_sim.sim_node import RigidBodySimNode

pytestmark = pytest.mark.ros

NODE_CLASSES = {
    "planner": FepfPlannerNode,
    "controller": PdControllerNode,
    "simulator": RigidBodySimNode,
}
GRAPH = {role: node_graph.node(role) for role in NODE_CLASSES}
ROS_TYPES = {
    "double": ParameterType.PARAMETER_DOUBLE,
    "double_array": ParameterType.PARAMETER_DOUBLE_ARRAY,
    "integer": ParameterType.PARAMETER_INTEGER,
    "string": ParameterType.PARAMETER_STRING,
    "string_array": ParameterType.PARAMETER_STRING_ARRAY,
    "bool": ParameterType.PARAMETER_BOOL,
}


# --- parameters ---------------------------------------------------------------------------


@pytest.mark.parametrize("which", sorted(NODE_CLASSES))
def test_scenario_parameters_declared_and_loaded(ros, scenario, which):
    ros.init(CASE1)
    node = ros.add(NODE_CLASSES[which]())
    table = GRAPH[which].parameters

    rows = scenario_keys(scenario.instrument_names, scenario.bright_object_names)
    assert len(rows) == len({r.key for r in rows}) > 20
    declared = [r for r in rows if table.reads_scenario_key(r.key)]
    assert declared and len(declared) < len(rows)  # each node declares only what it reads
    for row in rows:
        assert node.has_parameter(row.key) == table.reads_scenario_key(row.key), row.key
    for row in declared + list(table.own):
        d = node.describe_parameter(row.key)
        assert d.type == ROS_TYPES[row.ros_type], row.key
        assert d.read_only, row.key
        assert d.description.strip() and (row.rule is None or row.rule in d.description)
        closed = row.bounds.closed() if row.bounds is not None else None
        if closed is not None and row.ros_type == "double":
            assert len(d.floating_point_range) == 1, row.key
            r = d.floating_point_range[0]
            assert (r.from_value, r.to_value) == closed, row.key
        else:
            assert list(d.floating_point_range) == [], row.key
        if closed is not None and row.ros_type == "integer":  # e.g. planner.obstacle_samples
            assert len(d.integer_range) == 1, row.key
            r = d.integer_range[0]
            assert (r.from_value, r.to_value, r.step) == (closed[0], closed[1], 1), row.key
        else:
            assert list(d.integer_range) == [], row.key
    if which == "planner":
        assert node.describe_parameter("planner.obstacle_samples").integer_range
    else:  # the controller and the simulator do not carry the planner's keys
        assert not node.has_parameter("planner.gamma_deg")
    # Read-only for real: a set request is refused and the value is unchanged.
    key = "scenario_name"  # declared by every node that reads the scenario
    assert key in {r.key for r in declared}
    value = node.get_parameter(key).value
    result = node.set_parameters([Parameter(key, value=value)])[0]
    assert not result.successful

    # The node's scenario is the loader's, field by field ('source' names the node).
    assert node.get_fully_qualified_name() in node.scenario.source
    for field in dataclasses.fields(Scenario):
        if field.name == "source":
            continue
        got, want = getattr(node.scenario, field.name), getattr(scenario, field.name)
        if isinstance(want, np.ndarray):
            assert got.shape == want.shape, field.name
            np.testing.assert_array_equal(got, want, err_msg=field.name)
        else:
            assert got == want, field.name


def test_simulator_own_parameters_have_descriptors(ros):
    ros.init(CASE1)
    sim = ros.add(RigidBodySimNode())
    own = {
        "time_mode": ParameterType.PARAMETER_STRING,
        "lockstep.expected_subscribers": ParameterType.PARAMETER_INTEGER,
        "lockstep.resend_period_s": ParameterType.PARAMETER_DOUBLE,
        "lockstep.torque_timeout_s": ParameterType.PARAMETER_DOUBLE,
        "startup_timeout_s": ParameterType.PARAMETER_DOUBLE,
    }
    for name, ros_type in own.items():
        assert sim.has_parameter(name), name
        d = sim.describe_parameter(name)
        assert d.type == ros_type, name
        assert d.read_only, name
        assert d.description.strip(), name
        value = sim.get_parameter(name).value
        if ros_type == ParameterType.PARAMETER_DOUBLE:
            assert len(d.floating_point_range) == 1, name
            r = d.floating_point_range[0]
            assert r.from_value < r.to_value and r.from_value <= value <= r.to_value, name
    assert sim.get_parameter("time_mode").value == "lockstep"  # the documented default
    assert sim.get_parameter("lockstep.expected_subscribers").value >= 1
    # Its defaults do not leak into the other nodes.
    planner = ros.add(FepfPlannerNode())
    assert not any(planner.has_parameter(n) for n in own)


# --- bad parameter values -----------------------------------------------------------------


def _edit_case1(text: str, case: str) -> str:
    if case == "half_angle_out_of_range":
        new = text.replace("half_angle_deg: 20.0", "half_angle_deg: 95.0")
    elif case == "dt_integer":
        new = text.replace("dt_s: 0.1 ", "dt_s: 1 ")
    elif case == "desired_missing":
        new = "\n".join(
            line for line in text.splitlines() if not line.lstrip().startswith("desired_mrp:")
        )
    elif case == "kp_negative":
        new = text.replace("kp_over_j: 5.5", "kp_over_j: -5.5")
    assert new != text, case
    return new


BAD_CASES = {
    "half_angle_out_of_range": "instruments.star_tracker.half_angle_deg",
    "dt_integer": "dt_s",
    "desired_missing": "desired_mrp",
    "kp_negative": "controller.kp_over_j",
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
@pytest.mark.parametrize("which", sorted(NODE_CLASSES))
def test_bad_parameter_raises_scenario_error_naming_the_key(ros, tmp_path, which, case):
    path = tmp_path / f"{case}.yaml"
    path.write_text(_edit_case1(CASE1.read_text(), case))
    with pytest.raises(ScenarioError) as info:  # the offline loader agrees
        load_scenario(path)
    assert info.value.key == BAD_CASES[case]

    ros.init(path)
    with pytest.raises(ScenarioError) as info:
        NODE_CLASSES[which]()
    assert info.value.key == BAD_CASES[case], str(info.value)


def test_simulator_refuses_an_unknown_time_mode(ros):
    ros.init(CASE1, time_mode="fast")
    with pytest.raises(NodeParameterError) as info:
        RigidBodySimNode()
    assert info.value.key == "time_mode"
    assert "must be one of ['lockstep', 'realtime']" in str(info.value)


@pytest.mark.parametrize(
    "key, value, reason",
    [
        ("lockstep.expected_subscribers", -5, "out of range"),  # the row's integer range
        ("lockstep.max_held_steps", -1, "out of range"),
        ("time_mode", 1, "InvalidParameterTypeException"),  # the row's type
    ],
)
def test_node_own_parameters_are_checked_by_their_rows(ros, key, value, reason):
    """Overrides given to the constructor (``**kwargs`` reach ``Node.__init__``) are
    checked like the command line's: a NodeParameterError naming the key."""
    ros.init(CASE1)
    with pytest.raises(NodeParameterError) as info:
        RigidBodySimNode(parameter_overrides=[Parameter(key, value=value)])
    assert info.value.key == key
    assert reason in str(info.value)


def test_recorder_refuses_an_unknown_parameter_but_takes_a_shared_scenario_file(
    ros, tmp_path, scenario
):
    """The recorder declares no scenario key: given the shared ``/**`` scenario file it
    attaches that scenario to the bag, but a typo in its own parameters is refused."""
    ros.init(CASE1)
    with pytest.raises(NodeParameterError) as info:
        BagRecorderNode(
            parameter_overrides=[
                Parameter("output_dir", value=str(tmp_path / "a")),
                Parameter("stop_delay", value=5.0),  # a typo of stop_delay_s
            ]
        )
    assert info.value.key == "stop_delay"
    assert "did you mean 'stop_delay_s'?" in str(info.value)
    assert not (tmp_path / "a").exists()  # nothing half-written
    bag = tmp_path / "b"
    recorder = ros.add(
        BagRecorderNode(
            parameter_overrides=[
                Parameter("output_dir", value=str(bag)),
                Parameter("stop_on_planner_status", value=[PlannerStatus.ARRIVED.value]),
            ]
        )
    )
    assert recorder.stop_rule.stop_on == {PlannerStatus.ARRIVED}
    assert not recorder.has_parameter("dt_s")  # declares only its own table
    recorder.close()
    assert (bag / "metadata.yaml").is_file()
    # The scenario it was given (the nodes' --params-file) travels in the bag.
    attached = scenario_from_bag(str(bag))
    for field in dataclasses.fields(Scenario):
        if field.name == "source":
            continue
        got, want = getattr(attached, field.name), getattr(scenario, field.name)
        if isinstance(want, np.ndarray):
            np.testing.assert_array_equal(got, want, err_msg=field.name)
        else:
            assert got == want, field.name


def test_recorder_refuses_a_stop_status_that_is_not_a_planner_status(ros, tmp_path):
    ros.init(CASE1)
    with pytest.raises(NodeParameterError) as info:
        BagRecorderNode(
            parameter_overrides=[
                Parameter("output_dir", value=str(tmp_path / "bag")),
                Parameter("stop_on_planner_status", value=["arrivd"]),
            ]
        )
    assert info.value.key == "stop_on_planner_status"
    assert "'arrivd' is not a planner status" in str(info.value)
    assert not (tmp_path / "bag").exists()


def test_nodes_accept_an_injected_context(ros, scenario):
    """A node can live in a private rclpy context (``context=`` reaches ``Node.__init__``)."""
    ros.init(CASE1)
    ctx = rclpy.Context()
    rclpy.init(
        context=ctx,
        args=["--ros-args", "--params-file", str(CASE1), "-p", "autostart:=true"],
        domain_id=ros.domain_id,
    )
    try:
        for node_class in NODE_CLASSES.values():
            node = node_class(context=ctx)
            try:
                assert node.context is ctx
                assert node.scenario.name == scenario.name
            finally:
                node.destroy_node()
    finally:
        ctx.try_shutdown()


def test_relative_fis_path_resolves_against_the_working_directory(ros, tmp_path, monkeypatch):
    fis = ROOT / "src" / "attitude_core" / "attitude_core" / "data" / "fis_attractive.yaml"
    (tmp_path / "my_fis.yaml").write_text(fis.read_text())
    path = tmp_path / "relative_fis.yaml"
    planner_block = "    planner:\n      fis_attractive: ./my_fis.yaml\n"
    path.write_text(
        CASE1.read_text().replace("    controller:\n", planner_block + "    controller:\n")
    )
    assert load_scenario(path).planner.fis_attractive == str(tmp_path / "my_fis.yaml")
    monkeypatch.chdir(tmp_path)  # attitude-run starts the nodes in the scenario's directory
    ros.init(path)
    node = ros.add(FepfPlannerNode())
    assert node.scenario.planner.fis_attractive == str(tmp_path / "my_fis.yaml")


def test_unknown_key_is_refused_by_the_nodes_as_by_the_loader(ros, tmp_path):
    path = tmp_path / "typo.yaml"
    path.write_text(CASE1.read_text().replace("kp_over_j: 5.5", "kp_over_jj: 50.5"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.key == "controller.kp_over_jj"
    ros.init(path)
    for node_class in NODE_CLASSES.values():
        with pytest.raises(ScenarioError) as info:
            node_class()
        assert info.value.key == "controller.kp_over_jj"
        assert "did you mean 'controller.kp_over_j'" in str(info.value)
