"""In-process tests of the three rclpy node shells: real rclpy, real DDS, one process.

Each test gets its own ROS 2 session (``ros`` fixture): the default context initialised
with the test's ``--ros-args`` on a DDS domain reserved for the test (``ros_domain`` of
conftest.py), discovery limited to this host, and shut down afterwards. (The node
classes call ``Node.__init__`` without a context, so they live in the default context;
a private ``rclpy.Context`` per test is not possible without changing them.) Everything
is driven by one ``SingleThreadedExecutor`` holding the node under test and a test-side
``probe`` node.

Waiting is always for a condition, with a generous deadline (``WAIT_S``), never for a
time; nothing asserts on timing. "Nothing was published" is asserted deterministically
where possible: messages of one topic from one publisher arrive in order, so once the
answer to a later, valid message has arrived, an answer to an earlier rejected one would
have arrived before it. The nodes' own counters (``rejected``, ``pending``) tell when a
message has been consumed.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import ParameterType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from attitude_bringup.recorder_node import BagRecorderNode
from attitude_controller.controller_node import PdControllerNode
from attitude_core import (
    diagnostics,
    node_graph,
)
from attitude_core.control import PdGains, pd_torque
from attitude_core.dynamics import RigidBody
from attitude_core.fepf import FepfPlanner
from attitude_core.guidance import Guidance
from attitude_core.mrp import mrp_from_quat, quat_from_mrp
from attitude_core.parameters import NodeParameterError
from attitude_core.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    scenario_keys,
)
from attitude_core.status import PlannerStatus
from attitude_planner.planner_node import FepfPlannerNode
from attitude_ros import contract as c
from attitude_ros.convert import set_stamp, stamp_ns
from attitude_tools.bag_run import scenario_from_bag
from spacecraft_sim.sim_node import RigidBodySimNode

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.ros

CASE1 = ROOT / "scenarios" / "case1.yaml"
WAIT_S = 10.0  # deadline of every wait for a condition
QUIET_S = 0.3  # extra spinning before a (supplementary) "nothing arrived" check
TOL = 1e-12
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


# --- the ROS session fixture and its helpers -------------------------------------------


class RosSession:
    """One rclpy session: init with the test's arguments, an executor, a probe node."""

    def __init__(self, domain_id: int) -> None:
        self.domain_id = domain_id
        self.executor = None
        self.probe = None
        self.nodes: list[Node] = []

    def init(self, params_file: Path | str = CASE1, **overrides) -> None:
        """``rclpy.init`` with ``--params-file params_file`` and ``-p key:=value`` overrides
        (keyword names use ``__`` for the dots: ``lockstep__resend_period_s=0.05``)."""
        args = ["--ros-args", "--params-file", str(params_file)]
        for key, value in overrides.items():
            args += ["-p", f"{key.replace('__', '.')}:={value!r}"]
        rclpy.init(args=args, domain_id=self.domain_id)
        self.executor = SingleThreadedExecutor()
        self.probe = self.add(Node("node_shells_probe"))

    def add(self, node: Node) -> Node:
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def close(self) -> None:
        if self.executor is not None:
            self.executor.shutdown(timeout_sec=1.0)
        for node in reversed(self.nodes):
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()

    # -- spinning

    def spin_until(self, condition, what: str, timeout: float = WAIT_S) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.01)

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    # -- probe endpoints (the contract's QoS)

    def publisher(self, name: str):
        topic = c.topic(name)
        return self.probe.create_publisher(c.message_class(topic.type_name), name, c.qos(topic))

    def subscribe(self, name: str, *, history: bool = False) -> list:
        """Subscribe the probe to a contract topic; returns the list the messages go to.
        ``history``: transient-local, so samples published before matching arrive too."""
        topic = c.topic(name)
        received: list = []
        self.probe.create_subscription(
            c.message_class(topic.type_name),
            name,
            received.append,
            c.qos(topic, subscriber=not history),
        )
        return received

    def wait_connected(self, node: Node, publishers) -> None:
        """Wait until every probe publisher in ``publishers`` is matched by ``node``
        (both ends) and every probe subscription sees a publisher."""

        def node_subscription(name):
            return next(s for s in node.subscriptions if s.topic_name == name)

        def ready():
            return all(
                p.get_subscription_count() >= 1
                and node_subscription(p.topic_name).get_publisher_count() >= 1
                for p in publishers
            ) and all(s.get_publisher_count() >= 1 for s in self.probe.subscriptions)

        self.spin_until(ready, "the probe and the node to be connected")


@pytest.fixture
def ros(monkeypatch, ros_domain):
    """A fresh ROS 2 session on a reserved domain, local discovery only; shut down after."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    session = RosSession(domain_id=ros_domain)
    yield session
    session.close()


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    sc = load_scenario(CASE1)
    assert round(sc.dt_s * 1e9) == DT_NS
    return sc


# --- message helpers --------------------------------------------------------------------

DT_NS = 100_000_000  # case1: dt_s = 0.1


def stamped(msg, ns: int, frame: str = ""):
    set_stamp(msg.header.stamp, ns)
    msg.header.frame_id = frame
    return msg


def attitude_msg(ns: int, quat_xyzw) -> QuaternionStamped:
    msg = stamped(QuaternionStamped(), ns, c.INERTIAL_FRAME)
    q = msg.quaternion
    q.x, q.y, q.z, q.w = (float(x) for x in quat_xyzw)
    return msg


def vector_msg(ns: int, v, frame: str) -> Vector3Stamped:
    msg = stamped(Vector3Stamped(), ns, frame)
    msg.vector.x, msg.vector.y, msg.vector.z = (float(x) for x in v)
    return msg


def torque_msg(ns: int, u) -> WrenchStamped:
    msg = stamped(WrenchStamped(), ns, c.BODY_FRAME)
    t = msg.wrench.torque
    t.x, t.y, t.z = (float(x) for x in u)
    return msg


def xyz(v) -> np.ndarray:
    return np.array((v.x, v.y, v.z))


def xyzw(q) -> np.ndarray:
    return np.array((q.x, q.y, q.z, q.w))


def stamps(messages) -> list[int]:
    return [stamp_ns(m.header.stamp) for m in messages]


def assert_close(actual, expected, tol: float = TOL) -> None:
    np.testing.assert_allclose(
        np.asarray(actual, dtype=float), np.asarray(expected, dtype=float), rtol=0.0, atol=tol
    )


# --- 1. parameters ------------------------------------------------------------------------


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


# --- 2. bad parameter values --------------------------------------------------------------


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
    assert recorder.stop.stop_on == {PlannerStatus.ARRIVED}
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
        context=ctx, args=["--ros-args", "--params-file", str(CASE1)], domain_id=ros.domain_id
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


# --- 3. planner shell ---------------------------------------------------------------------


class PlannerProbe:
    """The planner node, an attitude publisher and subscriptions to all its outputs."""

    def __init__(self, ros: RosSession) -> None:
        self.ros = ros
        self.node = ros.add(FepfPlannerNode())
        self.pub = ros.publisher(c.ATTITUDE)
        self.pub_rate = ros.publisher(c.ANGULAR_VELOCITY)
        self.mrp = ros.subscribe(c.TARGET_MRP)
        self.rate = ros.subscribe(c.TARGET_RATE)
        self.margin = ros.subscribe(c.KEEP_OUT_MARGIN)
        self.diag = ros.subscribe(c.DIAGNOSTICS)
        self.status = ros.subscribe(c.PLANNER_STATUS, history=True)
        ros.wait_connected(self.node, [self.pub, self.pub_rate])

    def answers(self) -> int:
        return min(len(self.mrp), len(self.rate), len(self.margin), len(self.diag))

    def send(self, ns: int, quat) -> None:
        self.pub.publish(attitude_msg(ns, quat))

    def send_and_wait(self, ns: int, quat, omega=(0.0, 0.0, 0.0)) -> int:
        """Publish a state (rate, then attitude) and wait for the full answer; returns
        its index."""
        n = self.answers()
        self.pub_rate.publish(vector_msg(ns, omega, c.BODY_FRAME))
        self.send(ns, quat)
        self.ros.spin_until(lambda: self.answers() >= n + 1, f"the planner's answer to {ns} ns")
        assert self.answers() == n + 1
        return n

    def send_rejected(self, ns: int, quat) -> None:
        n = self.node.rejected
        self.send(ns, quat)
        self.ros.spin_until(lambda: self.node.rejected == n + 1, f"rejection of {ns} ns")


def test_planner_answers_each_stamp_with_the_core_planner(ros, scenario):
    ros.init(CASE1)
    p = PlannerProbe(ros)
    path = FepfPlanner.from_scenario(scenario)
    exact = scenario.cone_geometry()
    # Measured attitudes: the start, then along the FEPF's own target path; the node's
    # answers are the core guidance's for those states (at rest: zero rate).
    n_steps = 12
    fepf = [path.step() for _ in range(n_steps + 2)]
    measured = [scenario.initial_mrp] + [o.sigma_t for o in fepf[1:]]
    reference = Guidance.from_scenario(scenario)
    expected = [
        reference.update(k * DT_NS / 1e9, measured[k], np.zeros(3)).target
        for k in range(n_steps + 2)
    ]

    def check_answer(i: int, ns: int, k: int, sigma_measured) -> None:
        mrp, rate = p.mrp[i], p.rate[i]
        assert stamp_ns(mrp.header.stamp) == stamp_ns(rate.header.stamp) == ns
        assert stamp_ns(p.diag[i].header.stamp) == ns
        assert mrp.header.frame_id == c.INERTIAL_FRAME == "inertial"
        assert rate.header.frame_id == c.TARGET_FRAME == "target"
        assert_close(xyz(mrp.vector), expected[k].sigma_t)
        assert_close(xyz(rate.vector), expected[k].omega_t)
        sigma_node = mrp_from_quat(quat_from_mrp(sigma_measured))  # what the node decodes
        assert_close(p.margin[i].data, exact.min_margin_deg(sigma_node), 1e-9)
        assert p.margin[i].data > 0.0
        assert p.diag[i].status[0].message == expected[k].status

    for k in range(n_steps):
        i = p.send_and_wait(k * DT_NS, quat_from_mrp(measured[k]))
        check_answer(i, k * DT_NS, k, measured[k])
    # The target moves (the test is not vacuous).
    assert np.linalg.norm(xyz(p.mrp[-1].vector) - scenario.initial_mrp) > 1e-3
    assert all(o.status == PlannerStatus.TRACKING for o in expected[:n_steps])
    ros.spin_until(lambda: len(p.status) >= 1, "/planner/status")
    # latched, published on change only
    assert [m.data for m in p.status] == [PlannerStatus.TRACKING]

    # A repeated stamp: the identical answer again, the planner does not advance.
    last = n_steps - 1
    i = p.send_and_wait(last * DT_NS, quat_from_mrp(measured[last]))
    for topic in (p.mrp, p.rate):
        assert topic[i] == topic[i - 1]
    assert p.margin[i].data == p.margin[i - 1].data
    i = p.send_and_wait(n_steps * DT_NS, quat_from_mrp(measured[n_steps]))
    check_answer(i, n_steps * DT_NS, n_steps, measured[n_steps])

    # Rejected: an older stamp, a NaN, a zero and a non-unit quaternion. Nothing answers.
    answered, rejected = p.answers(), p.node.rejected
    next_ns = (n_steps + 1) * DT_NS
    good = quat_from_mrp(measured[n_steps + 1])
    p.send_rejected(3 * DT_NS, good)
    p.send_rejected(next_ns, (math.nan, 0.0, 0.0, 1.0))
    p.send_rejected(next_ns, (0.0, 0.0, 0.0, 0.0))
    p.send_rejected(next_ns, 1.01 * good)
    p.send_rejected(next_ns, (0.0, math.inf, 0.0, 1.0))
    assert p.node.rejected == rejected + 5
    ros.spin_for(QUIET_S)
    assert p.answers() == answered
    # The next valid state is answered as the next planner step: the rejected ones did
    # not advance it, and (same-topic order) nothing was published for them before it.
    i = p.send_and_wait(next_ns, good)
    assert i == answered
    check_answer(i, next_ns, n_steps + 1, measured[n_steps + 1])
    diag_values = {kv.key: kv.value for kv in p.diag[i].status[0].values}
    assert diag_values[diagnostics.REJECTED_MESSAGES] == str(rejected + 5)
    assert [m.data for m in p.status] == [PlannerStatus.TRACKING]


# --- 4. controller shell ------------------------------------------------------------------


class ControllerProbe:
    """The controller node, a publisher per input and a torque subscription."""

    def __init__(self, ros: RosSession, scenario: Scenario) -> None:
        self.ros = ros
        self.node = ros.add(PdControllerNode())
        self.gains = PdGains(scenario.kp, scenario.kd)
        self.pubs = [ros.publisher(name) for name in node_graph.CONTROLLER.subscribes]
        self.torque = ros.subscribe(c.TORQUE)
        ros.wait_connected(self.node, self.pubs)

    @staticmethod
    def message(slot: int, ns: int, value):
        if slot == 0:
            return attitude_msg(ns, value)
        frame = (c.BODY_FRAME, c.INERTIAL_FRAME, c.TARGET_FRAME)[slot - 1]
        return vector_msg(ns, value, frame)

    def filled(self, ns: int) -> int:
        return sum(x is not None for x in self.node.intake.pending.get(ns, ()))

    def feed(self, slot: int, ns: int, value) -> None:
        """Publish one input and wait until the node holds it (it is then pending)."""
        n = self.filled(ns)
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: self.filled(ns) == n + 1, f"input {slot} of {ns} ns")

    def feed_rejected(self, slot: int, ns: int, value) -> None:
        n = self.node.rejected
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: self.node.rejected == n + 1, f"rejection of {slot}")

    def feed_last(self, slot: int, ns: int, value) -> WrenchStamped:
        """Publish the input that completes a stamp and wait for its torque."""
        n = len(self.torque)
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: len(self.torque) > n, f"the torque of {ns} ns")
        assert len(self.torque) == n + 1
        return self.torque[-1]

    def expected(self, inputs) -> np.ndarray:
        quat, omega, sigma_t, omega_t = inputs
        return pd_torque(self.gains, mrp_from_quat(np.asarray(quat)), omega, sigma_t, omega_t)


def random_inputs(rng) -> list:
    """(quaternion of the body, omega_B, sigma_t, omega_t) for one stamp."""

    def mrp():
        v = rng.normal(size=3)
        return v / np.linalg.norm(v) * rng.uniform(0.05, 0.8)

    return [
        quat_from_mrp(mrp()),
        rng.normal(scale=0.1, size=3),
        mrp(),
        rng.normal(scale=0.05, size=3),
    ]


def check_torque(msg: WrenchStamped, ns: int, expected) -> None:
    assert stamp_ns(msg.header.stamp) == ns
    assert msg.header.frame_id == c.BODY_FRAME == "body"
    assert_close(xyz(msg.wrench.torque), expected)
    assert xyz(msg.wrench.force).tolist() == [0.0, 0.0, 0.0]


def test_controller_torque_per_stamp_in_any_input_order(ros, scenario):
    ros.init(CASE1)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(20240295)
    orders = list(itertools.permutations(range(4)))[::5]  # 5 different orders
    assert len({o[-1] for o in orders}) == 4  # each input comes last once
    for k, order in enumerate(orders, start=1):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        for slot in order[:-1]:
            p.feed(slot, ns, inputs[slot])
        ros.spin_for(QUIET_S)
        assert not any(stamp_ns(m.header.stamp) == ns for m in p.torque), order
        msg = p.feed_last(order[-1], ns, inputs[order[-1]])
        check_torque(msg, ns, p.expected(inputs))
        assert np.linalg.norm(p.expected(inputs)) > 1e-2  # a real torque, not zeros

    # A lockstep re-send of the state (same stamp) gets the identical torque again.
    msg = p.feed_last(0, ns, inputs[0])
    assert msg == p.torque[-2]
    assert stamps(p.torque) == [k * DT_NS for k in range(1, len(orders) + 1)] + [ns]

    # Interleaved stamps: a stamp completed later keeps its own inputs.
    ns_a, ns_b = (len(orders) + 1) * DT_NS, (len(orders) + 2) * DT_NS
    in_a, in_b = random_inputs(rng), random_inputs(rng)
    for slot in (0, 1, 2):
        p.feed(slot, ns_a, in_a[slot])
        p.feed(3 - slot, ns_b, in_b[3 - slot])
    check_torque(p.feed_last(3, ns_a, in_a[3]), ns_a, p.expected(in_a))
    check_torque(p.feed_last(0, ns_b, in_b[0]), ns_b, p.expected(in_b))


def test_controller_rejects_non_finite_inputs(ros, scenario):
    ros.init(CASE1)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(7)
    bad_values = {
        0: [(math.nan, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.6, 0.6)],
        1: [(0.0, math.nan, 0.0)],
        2: [(0.1, 0.0, math.inf)],
        3: [(-math.inf, 0.0, 0.0)],
    }
    n_bad = 0
    for k, slot in enumerate(sorted(bad_values), start=1):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        for other in range(4):
            if other != slot:
                p.feed(other, ns, inputs[other])
        for bad in bad_values[slot]:
            p.feed_rejected(slot, ns, bad)
            n_bad += 1
        assert p.filled(ns) == 3
        ros.spin_for(QUIET_S)
        assert not any(stamp_ns(m.header.stamp) == ns for m in p.torque)
        # The valid value completes the stamp; the torque is computed from it alone.
        msg = p.feed_last(slot, ns, inputs[slot])
        check_torque(msg, ns, p.expected(inputs))
    assert p.node.rejected == n_bad
    assert stamps(p.torque) == [k * DT_NS for k in range(1, 5)]
    assert all(np.isfinite(xyz(m.wrench.torque)).all() for m in p.torque)


def test_controller_rejects_inputs_stamped_before_its_last_torque(ros, scenario):
    ros.init(CASE1)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(11)
    inputs = random_inputs(rng)
    for slot in range(3):
        p.feed(slot, 5 * DT_NS, inputs[slot])
    check_torque(p.feed_last(3, 5 * DT_NS, inputs[3]), 5 * DT_NS, p.expected(inputs))
    old = random_inputs(rng)
    for slot in range(4):  # a whole state from the past: every input refused
        p.feed_rejected(slot, 4 * DT_NS, old[slot])
    assert p.node.rejected == 4
    ros.spin_for(QUIET_S)
    assert stamps(p.torque) == [5 * DT_NS]


# --- 5. simulator shell (lockstep) ----------------------------------------------------------


class SimProbe:
    """The simulator in lockstep with the smallest graph its start-up wait accepts.

    ``node_graph.readiness(e)`` asks for ``e`` attitude listeners, ``e - 1`` listeners of
    the rate, target and torque topics (the simulator's own torque subscription counts),
    a torque publisher and the two target publishers. With ``e = 1``: the probe's
    attitude subscription, its torque publisher and two target publishers.
    The probe's state subscriptions are transient-local, so they see every sample even
    if one of them matches after the simulator has started.
    """

    def __init__(self, ros: RosSession, scenario: Scenario) -> None:
        self.ros = ros
        self.attitude = ros.subscribe(c.ATTITUDE, history=True)
        self.rate = ros.subscribe(c.ANGULAR_VELOCITY, history=True)
        self.clock = ros.subscribe(c.CLOCK, history=True)
        self.pub_torque = ros.publisher(c.TORQUE)
        self.pub_target = ros.publisher(c.TARGET_MRP)
        self.pub_target_rate = ros.publisher(c.TARGET_RATE)
        self.node = ros.add(RigidBodySimNode())
        assert self.node.ready == node_graph.readiness(1)
        assert self.node.stepper.cfg.torque_timeout_s == 600.0
        self.reference = RigidBody(
            scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s
        )
        self.dt_s = scenario.dt_s

    def wait_state(self, ns: int) -> None:
        def arrived():
            return all(
                ns in s
                for s in (
                    stamps(self.attitude),
                    stamps(self.rate),
                    [stamp_ns(m.clock) for m in self.clock],
                )
            )

        self.ros.spin_until(arrived, f"the state stamped {ns} ns")

    def state(self, ns: int):
        """The first attitude and rate messages stamped ``ns``."""
        att = next(m for m in self.attitude if stamp_ns(m.header.stamp) == ns)
        rate = next(m for m in self.rate if stamp_ns(m.header.stamp) == ns)
        return att, rate

    def check_state(self, ns: int) -> None:
        """The state stamped ``ns`` is the reference body's, with the contract's frames."""
        att, rate = self.state(ns)
        assert att.header.frame_id == c.INERTIAL_FRAME
        assert rate.header.frame_id == c.BODY_FRAME
        assert_close(xyzw(att.quaternion), quat_from_mrp(self.reference.sigma_bn))
        assert_close(mrp_from_quat(xyzw(att.quaternion)), self.reference.sigma_bn)
        assert_close(xyz(rate.vector), self.reference.omega_b)

    def newest(self) -> int:
        return max(stamps(self.attitude), default=-1)

    def torque(self, ns: int, u) -> None:
        self.pub_torque.publish(torque_msg(ns, u))

    def reject_torque(self, ns: int, u) -> None:
        n = self.node.rejected
        self.torque(ns, u)
        self.ros.spin_until(lambda: self.node.rejected == n + 1, "the torque's rejection")


LOCKSTEP_ARGS = {"lockstep__expected_subscribers": 1, "lockstep__torque_timeout_s": 600.0}


def test_simulator_lockstep_advances_only_on_the_matching_torque(ros, scenario):
    ros.init(CASE1, lockstep__resend_period_s=60.0, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)
    s.wait_state(0)
    s.check_state(0)
    assert_close(xyzw(s.state(0)[0].quaternion), quat_from_mrp(scenario.initial_mrp))
    assert_close(xyz(s.state(0)[1].vector), scenario.initial_rate_rad_s)
    assert s.node.stepper.k == 0

    torques = [
        np.array([0.3, -0.2, 0.1]),
        np.array([-0.5, 0.05, 0.4]),
        np.array([0.0, 0.0, 0.0]),
        np.array([1.0, 2.0, -1.5]),
    ]
    for k, u in enumerate(torques):
        ns, next_ns = k * DT_NS, (k + 1) * DT_NS
        # Torques that must not advance it: future and past stamps, then a NaN with the
        # right stamp (rejected). Same topic and publisher, so they are consumed in order:
        # once the NaN is counted, the wrong stamps have been seen and ignored.
        s.torque(next_ns, -10.0 * u + 1.0)
        s.torque(ns + 7 * DT_NS, -10.0 * u + 1.0)
        if k > 0:
            s.torque(ns - DT_NS, -10.0 * u + 1.0)
        s.reject_torque(ns, (math.nan, 0.0, 0.0))
        ros.spin_for(QUIET_S)
        assert s.node.stepper.k == k and s.newest() == ns
        # The right torque: exactly one step of the core's rigid body.
        s.torque(ns, u)
        s.wait_state(next_ns)
        s.reference.step(u, s.dt_s)
        s.check_state(next_ns)
        assert s.node.stepper.k == k + 1
    # Every state stamp in order, each once (no re-sends with a 60 s period), /clock too.
    expected = [k * DT_NS for k in range(len(torques) + 1)]
    assert stamps(s.attitude) == stamps(s.rate) == expected
    assert [stamp_ns(m.clock) for m in s.clock] == expected
    assert s.node.stepper.timeouts == 0 and s.node.stepper.resends == 0
    # Physics, not a constant: the body turned and spins.
    assert np.linalg.norm(s.reference.omega_b) > 1e-3
    assert np.linalg.norm(s.reference.sigma_bn - scenario.initial_mrp) > 1e-5


def test_simulator_lockstep_resends_the_state_while_the_torque_is_missing(ros, scenario):
    ros.init(CASE1, lockstep__resend_period_s=0.05, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)

    def resent(ns: int, times: int = 3):
        s.ros.spin_until(
            lambda: stamps(s.attitude).count(ns) >= times and stamps(s.rate).count(ns) >= times,
            f"{times} sends of the state stamped {ns} ns",
        )
        same = [m for m in s.attitude if stamp_ns(m.header.stamp) == ns]
        assert all(m == same[0] for m in same)
        same = [m for m in s.rate if stamp_ns(m.header.stamp) == ns]
        assert all(m == same[0] for m in same)

    resent(0)
    assert s.node.stepper.k == 0 and s.node.stepper.resends >= 2
    s.check_state(0)
    u = np.array([0.2, 0.1, -0.3])
    s.torque(0, u)
    s.wait_state(DT_NS)
    s.reference.step(u, s.dt_s)
    s.check_state(DT_NS)
    resent(DT_NS)
    assert s.node.stepper.k == 1 and s.node.stepper.timeouts == 0
    # Stamps never go back: 0 (several times), then dt (several times).
    got = stamps(s.attitude)
    assert got == sorted(got) and set(got) == {0, DT_NS}
    assert [stamp_ns(m.clock) for m in s.clock] == sorted(stamp_ns(m.clock) for m in s.clock)


def test_simulator_realtime_refuses_torques_from_the_past_and_non_finite(ros, scenario):
    ros.init(CASE1, time_mode="realtime", realtime__torque_stale_s=600.0, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)
    ros.spin_until(lambda: s.newest() >= 0, "the first real-time state")
    now = s.newest()
    u = np.array([0.01, -0.02, 0.03])
    s.torque(now, u)
    ros.spin_until(lambda: s.node.stepper.torque_stamp == now, "the torque to be taken")
    np.testing.assert_array_equal(s.node.stepper.torque, u)
    s.torque(now - DT_NS, -u)  # stamped before the applied one
    s.torque(now + DT_NS, (math.nan, 0.0, 0.0))  # not finite
    ros.spin_until(lambda: s.node.rejected == 2, "two rejections")
    np.testing.assert_array_equal(s.node.stepper.torque, u)  # still the good one


def test_controller_rejects_inputs_in_another_frame(ros, scenario):
    """Each input's frame_id is the contract's (attitude ``inertial``, rate ``body``,
    targets ``inertial`` and ``target``): any other is rejected, counted, never torque."""
    ros.init(CASE1)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(11)
    ns = DT_NS
    inputs = random_inputs(rng)
    for slot in range(4):
        wrong = p.message(slot, ns, inputs[slot])
        wrong.header.frame_id = "base_link"
        n = p.node.rejected
        p.pubs[slot].publish(wrong)
        ros.spin_until(lambda n=n: p.node.rejected == n + 1, f"rejection of input {slot}")
    assert p.filled(ns) == 0  # nothing of the stamp was taken
    for slot in range(3):
        p.feed(slot, ns, inputs[slot])
    check_torque(p.feed_last(3, ns, inputs[3]), ns, p.expected(inputs))
    assert p.node.rejected == 4 and len(p.torque) == 1


def test_planner_rejects_an_attitude_in_another_frame(ros, scenario):
    ros.init(CASE1)
    p = PlannerProbe(ros)
    quat = quat_from_mrp(scenario.initial_mrp)
    for frame in ("body", "", "map"):
        msg = attitude_msg(0, quat)
        msg.header.frame_id = frame
        n = p.node.rejected
        p.pub.publish(msg)
        ros.spin_until(lambda n=n: p.node.rejected == n + 1, f"rejection of frame {frame!r}")
    assert p.answers() == 0 and p.node.guidance is None  # not even started from it
    p.send_and_wait(0, quat)
    assert p.node.rejected == 3


def test_best_effort_state_publisher_connects_through_qos_overrides(ros, scenario):
    """A sensor-data (best-effort) driver: refused by the default reliable subscription,
    connected with ROS 2's standard ``qos_overrides`` parameter."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    override = "qos_overrides./spacecraft/attitude.subscription.reliability"
    ros.init(CASE1, **{override.replace(".", "__"): "best_effort"})
    planner = ros.add(FepfPlannerNode())
    driver = ros.probe.create_publisher(
        QuaternionStamped,
        c.ATTITUDE,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    ros.spin_until(lambda: driver.get_subscription_count() >= 1, "the best-effort match")
    rate = ros.publisher(c.ANGULAR_VELOCITY)  # the other half of the state, reliable
    ros.wait_connected(planner, [rate])
    answers = ros.subscribe(c.TARGET_MRP)
    ros.spin_until(lambda: planner.pub_mrp.get_subscription_count() >= 1, "the answer's match")
    quat = quat_from_mrp(scenario.initial_mrp)
    ns = 0

    def answered() -> bool:  # best effort may drop a sample: publish until one is answered
        nonlocal ns
        if not answers:
            rate.publish(vector_msg(ns, (0.0, 0.0, 0.0), c.BODY_FRAME))
            driver.publish(attitude_msg(ns, quat))
            ns += DT_NS
        return bool(answers)

    ros.spin_until(answered, "the planner's answer to a best-effort state")
    assert planner.get_parameter(override).value == "best_effort"


def test_best_effort_state_publisher_does_not_connect_by_default(ros):
    """Without the override the state subscription stays reliable: lossless lockstep with
    the project's simulator; a best-effort publisher is incompatible and never matches."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    ros.init(CASE1)
    planner = ros.add(FepfPlannerNode())
    reliable = ros.publisher(c.ATTITUDE)  # a contract publisher matches: discovery works
    driver = ros.probe.create_publisher(
        QuaternionStamped,
        c.ATTITUDE,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    ros.spin_until(lambda: reliable.get_subscription_count() >= 1, "the reliable match")
    ros.spin_for(QUIET_S)
    assert driver.get_subscription_count() == 0
    assert planner.count_publishers(c.ATTITUDE) == 2  # both are seen, only one matches


def test_controller_scales_its_command_into_the_actuator_bound(ros, scenario, tmp_path):
    """With ``actuators.max_torque_nm`` the torque is the eq. 11 torque scaled into the
    per-axis bound, its direction kept."""
    from attitude_core.actuators import scale_to_bound

    bound = (0.03, 0.02, 0.05)
    path = tmp_path / "limited.yaml"
    path.write_text(
        CASE1.read_text().replace(
            "    controller:\n",
            f"    actuators:\n      max_torque_nm: {list(bound)}\n    controller:\n",
        )
    )
    ros.init(path)
    p = ControllerProbe(ros, scenario)
    assert p.node.has_parameter("actuators.max_torque_nm")
    assert not p.node.has_parameter("actuators.max_rate_rad_s")  # the planner's, not its
    rng = np.random.default_rng(5)
    saturated = 0
    for k in range(1, 9):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        inputs[1] = inputs[1] * 20.0  # fast body rates: large torques
        for slot in range(3):
            p.feed(slot, ns, inputs[slot])
        msg = p.feed_last(3, ns, inputs[3])
        want, hit = scale_to_bound(p.expected(inputs), bound)
        saturated += hit
        check_torque(msg, ns, want)
        assert np.all(np.abs(xyz(msg.wrench.torque)) <= np.array(bound) * (1 + 1e-12))
    assert saturated >= 4
