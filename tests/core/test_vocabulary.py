"""The shared vocabulary of the stack, without ROS: planner statuses
(:mod:`attitude_core.contract.status`), the planner's ``/diagnostics`` key/value contract
(:mod:`attitude_core.contract.diagnostics`) and the node graph
(:mod:`attitude_core.config.node_graph`),
checked against the topic contract, the packages' ``setup.py`` console scripts and the
topics the node sources really subscribe and publish (read with ``ast``, not imported).
"""

from __future__ import annotations

import ast
import inspect
import math
from pathlib import Path

import pytest

from attitude_core.config import node_graph as g
from attitude_core.config.node_parameters import CONTROLLER, PLANNER, RECORDER, SIMULATOR
from attitude_core.contract import topics as t
from attitude_core.contract.diagnostics import KEYS, PlannerDiagnostics
from attitude_core.contract.faults import FaultKind
from attitude_core.contract.status import DiagnosticLevel, PlannerStatus
from attitude_ros import endpoints as endpoints_module
from attitude_ros.goal_intake import subscribe_goal
from attitude_ros.intake import subscribe_paired, subscribe_wheel_torque
from attitude_ros.torque_out import TorqueOut
from attitude_ros.wheel_msgs import WheelTorqueOut, wheel_inputs

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
TOPIC_NAMES = {topic.name for topic in t.TOPICS}
COMMAND_NAMES = {topic.name for topic in t.COMMAND_TOPICS}  # an operator's (the goal)
# Constants of attitude_core.contract.topics that name a contract topic (c.ATTITUDE, ...).
TOPIC_CONSTANTS = {
    k: v
    for k, v in vars(t).items()
    if k.isupper() and isinstance(v, str) and v in TOPIC_NAMES | COMMAND_NAMES
}
# ... and those that name a tuple of them (c.STATE_TOPICS, c.SENSOR_TOPICS, ...).
TOPIC_TUPLES = {
    k: set(v)
    for k, v in vars(t).items()
    if k.isupper() and isinstance(v, tuple) and v and set(v) <= TOPIC_NAMES
}


# --- status ----------------------------------------------------------------------------


def test_planner_statuses_codes_levels_and_ends_slew():
    table = [(s.value, s.code, s.level, s.ends_slew) for s in PlannerStatus]
    assert table == [
        ("tracking", 0, DiagnosticLevel.OK, False),
        ("arrived", 1, DiagnosticLevel.OK, True),
        ("stuck", 2, DiagnosticLevel.WARN, True),
        ("infeasible", 3, DiagnosticLevel.ERROR, True),
        ("blocked", 4, DiagnosticLevel.WARN, False),
        ("safe_mode", 5, DiagnosticLevel.ERROR, True),
        ("refused", 6, DiagnosticLevel.WARN, False),
        ("complete", 7, DiagnosticLevel.OK, True),
    ]


def test_status_is_the_published_string():
    assert PlannerStatus("stuck") is PlannerStatus.STUCK
    assert PlannerStatus.ARRIVED == "arrived" and str(PlannerStatus.ARRIVED) == "arrived"
    assert f"{PlannerStatus.TRACKING}" == "tracking"
    with pytest.raises(ValueError):
        PlannerStatus("ARRIVED")
    for status in PlannerStatus:
        assert PlannerStatus.parse(status.value) is status
    with pytest.raises(ValueError, match="is not a planner status"):
        PlannerStatus.parse("ARRIVED")


def test_diagnostic_levels_are_the_message_byte_values():
    # diagnostic_msgs/DiagnosticStatus: OK=0 WARN=1 ERROR=2 STALE=3
    assert [(lv.name, int(lv)) for lv in DiagnosticLevel] == [
        ("OK", 0),
        ("WARN", 1),
        ("ERROR", 2),
        ("STALE", 3),
    ]


def test_from_code_inverts_code():
    codes = [s.code for s in PlannerStatus]
    assert len(set(codes)) == len(codes)
    for status in PlannerStatus:
        assert PlannerStatus.from_code(status.code) is status
    for bad in (-1, 8, 99):
        with pytest.raises(ValueError, match=f"no planner status has code {bad}"):
            PlannerStatus.from_code(bad)


def test_ending_statuses_in_code_order():
    assert PlannerStatus.ending() == (
        PlannerStatus.ARRIVED,
        PlannerStatus.STUCK,
        PlannerStatus.INFEASIBLE,
        PlannerStatus.SAFE_MODE,
        PlannerStatus.COMPLETE,
    )
    assert [s.code for s in PlannerStatus.ending()] == sorted(
        s.code for s in PlannerStatus if s.ends_slew
    )


def test_fault_kinds_their_levels_and_diagnostic_names():
    assert [(k.value, k.level, k.diagnostic_name) for k in FaultKind] == [
        ("state_lost", DiagnosticLevel.WARN, "fdir/state_lost"),
        ("star_tracker_outage", DiagnosticLevel.WARN, "fdir/star_tracker_outage"),
        ("safe_mode", DiagnosticLevel.ERROR, "fdir/safe_mode"),
    ]
    for kind in FaultKind:
        assert FaultKind.parse(kind.value) is kind
    with pytest.raises(ValueError, match="is not a fault kind"):
        FaultKind.parse("lost")


# --- diagnostics -----------------------------------------------------------------------

AWKWARD = [0.1 + 0.2, 1e-300, 5e-324, -0.0, 1.0 / 3.0, 123456789.123456789, -2.5e17]


def diag(
    status=PlannerStatus.TRACKING,
    step_time_s=1.234e-4,
    distance=0.1 + 0.2,
    margin=1.0 / 3.0,
    m_a=5e-324,
    m_r=-0.0,
    rejected=7,
) -> PlannerDiagnostics:
    return PlannerDiagnostics(status, step_time_s, distance, margin, m_a, m_r, rejected)


def same_float(a: float, b: float) -> bool:
    """Equal bit for bit in value and sign, NaN equal to NaN."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


def test_diagnostics_values_are_in_keys_order():
    values = diag().values()
    assert [k for k, _ in values] == list(KEYS)
    assert KEYS == (
        "status",
        "step_time_us",
        "obstacle_distance_mrp",
        "keep_out_margin_deg",
        "m_a",
        "m_r",
        "rejected_messages",
        "tracking_error_deg",
        "goal_error_deg",
        "speed_factor",
        "accel_derating",
        "route_rotation_deg",
        "route_waypoints",
        "reason",
        "goal_safe_until_s",
        "blocked_by",
        "blocked_from_s",
        "blocked_until_s",
    )
    assert all(isinstance(v, str) for _, v in values)
    assert dict(values)["status"] == "tracking"
    assert dict(values)["step_time_us"] == "123.400"  # microseconds, 3 decimals
    assert dict(values)["rejected_messages"] == "7"


@pytest.mark.parametrize("x", AWKWARD)
def test_diagnostics_round_trip_is_exact_for_floats(x):
    for status in PlannerStatus:
        d = diag(status, distance=x, margin=-x, m_a=x * 0.5, m_r=x)
        back = PlannerDiagnostics.from_values(dict(d.values()))
        assert back.status is status
        for name in ("obstacle_distance_mrp", "keep_out_margin_deg", "m_a", "m_r"):
            assert same_float(getattr(back, name), getattr(d, name)), name
        assert back.rejected_messages == d.rejected_messages


def test_diagnostics_step_time_to_the_nanosecond():
    d = diag(step_time_s=0.0123456789)
    back = PlannerDiagnostics.from_values(dict(d.values()))
    assert back.step_time_s == pytest.approx(0.0123456789, abs=0.5e-9)
    assert back.step_time_s != 0.0123456789  # 3 decimals of a microsecond


def test_diagnostics_non_finite_values_round_trip():
    nan, inf = float("nan"), float("inf")
    d = diag(step_time_s=nan, distance=inf, margin=-inf, m_a=nan, m_r=nan)
    back = PlannerDiagnostics.from_values(dict(d.values()))
    assert math.isnan(back.step_time_s) and math.isnan(back.m_a) and math.isnan(back.m_r)
    assert back.obstacle_distance_mrp == inf and back.keep_out_margin_deg == -inf


def test_diagnostics_missing_numbers_are_nan_and_count_minus_one():
    back = PlannerDiagnostics.from_values({"status": "arrived"})
    assert back.status is PlannerStatus.ARRIVED
    for name in ("step_time_s", "obstacle_distance_mrp", "keep_out_margin_deg", "m_a", "m_r"):
        assert math.isnan(getattr(back, name)), name
    assert back.rejected_messages == -1


def test_diagnostics_missing_status_raises():
    values = dict(diag().values())
    del values["status"]
    with pytest.raises(ValueError, match="planner diagnostics without a 'status' value"):
        PlannerDiagnostics.from_values(values)


def test_diagnostics_unknown_status_raises():
    values = dict(diag().values())
    values["status"] = "lost"
    with pytest.raises(ValueError, match="lost"):
        PlannerDiagnostics.from_values(values)


# --- node graph: the table -------------------------------------------------------------


def test_nodes_start_order_and_roles():
    assert [n.role for n in g.NODES] == ["recorder", "planner", "controller", "simulator"]
    assert g.NODES == (g.RECORDER, g.PLANNER, g.CONTROLLER, g.SIMULATOR)
    assert g.LOOP == (g.PLANNER, g.CONTROLLER, g.SIMULATOR)
    assert [set(wave) for wave in g.STOP_ORDER] == [set(g.LOOP), {g.RECORDER}]
    for spec in g.NODES:
        assert g.node(spec.role) is spec
    with pytest.raises(KeyError):
        g.node("bridge")


def test_each_node_has_its_parameter_table():
    assert [n.parameters for n in g.NODES] == [RECORDER, PLANNER, CONTROLLER, SIMULATOR]


def console_scripts(package: str) -> dict[str, str]:
    """``name -> module:function`` of the package's setup.py (parsed, not run)."""
    tree = ast.parse((SRC / package / "setup.py").read_text(encoding="utf-8"))
    for call in ast.walk(tree):
        if isinstance(call, ast.Call) and getattr(call.func, "id", None) == "setup":
            for kw in call.keywords:
                if kw.arg == "entry_points":
                    entry_points = ast.literal_eval(kw.value)
                    pairs = (s.split("=", 1) for s in entry_points.get("console_scripts", []))
                    return {name.strip(): target.strip() for name, target in pairs}
    raise AssertionError(f"no setup(entry_points=...) in src/{package}/setup.py")


def module_file(spec: g.NodeSpec) -> Path:
    package, module = spec.module.split(".")
    return SRC / spec.package / package / f"{module}.py"


@pytest.mark.parametrize("spec", g.SENSING_NODES, ids=lambda s: s.role)
def test_executable_is_a_console_script_of_its_package(spec):
    scripts = console_scripts(spec.package)
    assert spec.executable in scripts, scripts
    assert scripts[spec.executable] == f"{spec.module}:main"
    assert spec.module.split(".")[0] == spec.package


@pytest.mark.parametrize("spec", g.SENSING_NODES, ids=lambda s: s.role)
def test_node_module_is_a_real_file_with_main(spec):
    path = module_file(spec)
    assert path.is_file(), path
    tree = ast.parse(path.read_text(encoding="utf-8"))
    assert "main" in {f.name for f in tree.body if isinstance(f, ast.FunctionDef)}


@pytest.mark.parametrize("spec", g.SENSING_NODES, ids=lambda s: s.role)
def test_node_topics_are_contract_topics(spec):
    for name in spec.subscribes + spec.publishes:
        assert name in TOPIC_NAMES | COMMAND_NAMES, name
    assert not set(spec.publishes) & COMMAND_NAMES  # an operator's, never a node's
    assert len(set(spec.subscribes)) == len(spec.subscribes)
    assert len(set(spec.publishes)) == len(spec.publishes)


def test_every_contract_topic_has_exactly_one_publisher():
    # each node as wired for a wheel array: its topics and the wheel topics
    published = [name for n in g.NODES for name in g.with_wheels(n, True).publishes]
    assert sorted(published) == sorted(TOPIC_NAMES)


def test_every_loop_subscription_is_published():
    published = {name for n in g.NODES for name in n.publishes}
    state = {t.ATTITUDE, t.ANGULAR_VELOCITY}
    assert state <= set(g.SIMULATOR.publishes)
    for spec in g.LOOP:
        for name in spec.subscribes:
            if name in COMMAND_NAMES:  # an operator publishes it
                continue
            assert name in published or name in state, (spec.role, name)
            publishers = [n for n in g.NODES if name in n.publishes]
            assert spec not in publishers, (spec.role, name)  # no node feeds itself


def test_recorder_records_every_topic_and_publishes_nothing():
    assert set(g.RECORDER.subscribes) == TOPIC_NAMES | COMMAND_NAMES
    assert g.RECORDER.publishes == ()


def test_state_listeners():
    assert g.state_listeners() == 3
    assert g.state_listeners(g.LOOP) == 2
    assert g.state_listeners((g.SIMULATOR,)) == 0


@pytest.mark.parametrize("e", [1, 2, 3, 4])
def test_readiness_rule(e):
    r = g.readiness(e)
    assert r.min_subscribers == {
        t.ATTITUDE: e,
        t.ANGULAR_VELOCITY: e,
        t.TARGET_MRP: e - 1,
        t.TARGET_RATE: e - 1,
        t.TORQUE: e - 1,
    }
    assert r.min_publishers == {t.TARGET_MRP: 1, t.TARGET_RATE: 1, t.TORQUE: 1}


@pytest.mark.parametrize("sensing", [False, True])
def test_min_readers_are_the_real_readers_of_each_per_step_output(sensing):
    """The sure start: with the node table's listeners, each loop node's per-step output
    waits for exactly the nodes of the table that subscribe it (the recorder reads all;
    /diagnostics: the per-step writer, read by the recorder only, the guards' and the
    manager's identity readers being of the other durability)."""
    graph = g.graph(sensing)
    nodes = graph.nodes
    r = g.readiness(g.state_listeners(nodes), sensing)
    assert set(r.min_readers) == {spec.role for spec in graph.loop}
    for spec in graph.loop:
        wants = r.min_readers[spec.role]
        assert set(wants) <= set(g.per_step_outputs(spec))
        for name, n in wants.items():
            readers = [m for m in nodes if name in m.subscribes and name != t.DIAGNOSTICS]
            assert n == (1 if name == t.DIAGNOSTICS else len(readers)), (spec.role, name)
    assert r.min_readers["simulator"][t.CLOCK] >= 1  # the recorder's /clock from step 0
    assert t.PLANNER_STATUS not in r.min_readers["planner"]  # latched: late joiners get it
    assert g.readiness(2).min_readers["planner"] == {t.TARGET_MRP: 1, t.TARGET_RATE: 1}


def test_readiness_of_the_default_graph_counts_the_real_subscribers():
    """With the node table's listeners, each topic waits for exactly its subscribers."""
    r = g.readiness(g.state_listeners())
    for name, n in r.min_subscribers.items():
        assert n == sum(name in spec.subscribes for spec in g.NODES), name
    for name in r.min_publishers:
        assert sum(name in spec.publishes for spec in g.NODES) == 1


# --- node graph: the node sources ------------------------------------------------------

ENDPOINT_METHODS = {"create_subscription": "sub", "create_publisher": "pub"}
# attitude_ros.endpoints' helpers, called with (node, topic, ...).
ENDPOINT_FUNCTIONS = {
    endpoints_module.publisher.__name__: "pub",
    endpoints_module.subscription.__name__: "sub",
    endpoints_module.raw_subscription.__name__: "sub",
}
# attitude_ros.intake.subscribe_paired(node, guard, pairing, inputs, ...) subscribes the
# topic of each (topic, convert) row of ``inputs`` (a tuple, or a name bound to one).
PAIRED = subscribe_paired.__name__
PAIRED_INPUTS = list(inspect.signature(subscribe_paired).parameters).index("inputs")
# attitude_ros helpers that make a node's endpoints: what each call subscribes or publishes.
HELPERS = {
    subscribe_wheel_torque.__name__: ("sub", {t.WHEEL_TORQUE}),
    wheel_inputs.__name__: ("sub", {t.WHEEL_STATES}),  # a paired input row
    TorqueOut.__name__: ("pub", {t.TORQUE, t.WHEEL_TORQUE}),  # the latter with wheels
    WheelTorqueOut.__name__: ("pub", {t.WHEEL_TORQUE}),
    subscribe_goal.__name__: ("sub", {t.GOAL}),
}


def _topic_constants_in(node: ast.AST) -> set[str]:
    names = set()
    for sub in ast.walk(node):
        if isinstance(sub, ast.Attribute):
            if sub.attr == "TOPICS":
                names |= TOPIC_NAMES
            elif sub.attr == "COMMAND_TOPICS":
                names |= COMMAND_NAMES
            elif sub.attr in TOPIC_CONSTANTS:
                names.add(TOPIC_CONSTANTS[sub.attr])
            elif sub.attr in TOPIC_TUPLES:
                names |= TOPIC_TUPLES[sub.attr]
    return names


def _bound_names(target: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}


def _topics_of_argument(
    arg: ast.AST, loops: list[ast.For], bound: dict[str, ast.AST] | None = None
) -> set[str]:
    """The topic names an endpoint's topic argument can take: a contract constant
    (``c.ATTITUDE``), a variable bound by an enclosing ``for`` over constants or over
    ``c.TOPICS`` (``topic.name``), or a variable assigned from constants (every constant
    of the assigned expression: ``a, b = c.TRUTH_TOPICS if x else c.STATE_TOPICS``)."""
    if isinstance(arg, ast.Attribute) and arg.attr in TOPIC_CONSTANTS:
        return {TOPIC_CONSTANTS[arg.attr]}
    var = arg.value if isinstance(arg, ast.Attribute) and arg.attr == "name" else arg
    if isinstance(var, ast.Name):
        for loop in reversed(loops):
            if var.id in _bound_names(loop.target):
                names = _topic_constants_in(loop.iter)
                if names:
                    return names
        if bound and var.id in bound:
            names = _topic_constants_in(bound[var.id])
            if names:
                return names
    raise AssertionError(f"line {arg.lineno}: cannot resolve the topic of {ast.unparse(arg)!r}")


def endpoints(source: str) -> dict[str, set[str]]:
    """``{"sub": topics, "pub": topics}`` of the create_subscription / create_publisher
    calls in a node source, also through an alias: ``pub = self.create_publisher``, or
    ``pub = lambda kind, name: self.create_publisher(kind, name, ...)`` (the topic is then
    the lambda's argument at the position the endpoint call takes it from)."""
    tree = ast.parse(source)
    aliases: dict[str, str] = {}
    topic_index: dict[str, int] = {}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Assign):
            continue
        value, kind, index = node.value, None, 1
        if isinstance(value, ast.Attribute) and value.attr in ENDPOINT_METHODS:
            kind = ENDPOINT_METHODS[value.attr]
        elif (
            isinstance(value, ast.Lambda)
            and isinstance(value.body, ast.Call)
            and isinstance(value.body.func, ast.Attribute)
            and value.body.func.attr in ENDPOINT_METHODS
            and len(value.body.args) > 1
            and isinstance(value.body.args[1], ast.Name)
        ):
            params = [a.arg for a in value.args.args]
            kind = ENDPOINT_METHODS[value.body.func.attr]
            index = params.index(value.body.args[1].id)
        if kind is None:
            continue
        for target in node.targets:
            if isinstance(target, ast.Name):
                aliases[target.id] = kind
                topic_index[target.id] = index
    found: dict[str, set[str]] = {"sub": set(), "pub": set()}
    bound = {
        name.id: node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Assign)
        for target in node.targets
        for name in ([target] if isinstance(target, ast.Name) else ast.walk(target))
        if isinstance(name, ast.Name)
    }

    def visit(node: ast.AST, loops: list[ast.For]) -> None:
        if isinstance(node, ast.Lambda):
            return  # an alias's body: its calls are counted where the alias is called
        if isinstance(node, ast.Call):
            func = node.func
            kind = (
                ENDPOINT_METHODS.get(func.attr)
                if isinstance(func, ast.Attribute)
                else aliases.get(func.id, ENDPOINT_FUNCTIONS.get(func.id))
                if isinstance(func, ast.Name)
                else None
            )
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in HELPERS:
                helper_kind, helper_topics = HELPERS[name]
                found[helper_kind] |= helper_topics
            if name == PAIRED:
                rows = node.args[PAIRED_INPUTS]
                if isinstance(rows, ast.Name):
                    rows = bound[rows.id]
                assert isinstance(rows, ast.Tuple | ast.List), f"line {node.lineno}: inputs"
                for row in rows.elts:
                    if isinstance(row, ast.Starred):  # rows of a helper (HELPERS), visited
                        continue
                    assert isinstance(row, ast.Tuple), f"line {row.lineno}: an input row"
                    found["sub"] |= _topics_of_argument(row.elts[0], loops)
            if kind is not None:
                index = topic_index.get(func.id, 1) if isinstance(func, ast.Name) else 1
                topic = (
                    node.args[index]
                    if len(node.args) > index
                    else next((kw.value for kw in node.keywords if kw.arg == "topic"), None)
                )
                assert topic is not None, f"line {node.lineno}: an endpoint without a topic"
                found[kind] |= _topics_of_argument(topic, loops, bound)
        inner = loops + [node] if isinstance(node, ast.For) else loops
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(tree, [])
    return found


@pytest.mark.parametrize("spec", g.SENSING_NODES, ids=lambda s: s.role)
def test_node_sources_subscribe_and_publish_their_table_topics(spec):
    """Over the node's module and the package modules beside it (the simulator's sensor
    publishers are in their own), with and without wheels."""
    found: dict[str, set[str]] = {"sub": set(), "pub": set()}
    for path in sorted(module_file(spec).parent.glob("*.py")):
        for kind, names in endpoints(path.read_text(encoding="utf-8")).items():
            found[kind] |= names
    wheeled = g.with_wheels(spec, True)  # the same sources wire a wheel array's run
    assert found["sub"] == set(spec.subscribes) | set(wheeled.subscribes), spec.role
    assert found["pub"] == set(spec.publishes) | set(wheeled.publishes), spec.role


@pytest.mark.parametrize("spec", g.SENSING_NODES, ids=lambda s: s.role)
def test_node_sources_take_their_name_from_the_table(spec):
    text = module_file(spec).read_text(encoding="utf-8")
    # Named from the table directly, or through StackNode (which takes spec.node_name
    # from the class's ``spec``).
    assert (
        f"node_graph.{spec.role.upper()}.node_name" in text
        or f"    spec = node_graph.{spec.role.upper()}\n" in text
    )
    assert f"node_graph.{spec.role.upper()}.parameters" in text


@pytest.mark.parametrize(
    "source, expected",
    [
        ("self.create_publisher(A, c.TARGET_MRP, q)", {"sub": set(), "pub": {t.TARGET_MRP}}),
        (
            "pub = self.create_publisher\npub(A, c.TARGET_RATE, q)",
            {"sub": set(), "pub": {t.TARGET_RATE}},
        ),
        (
            "pub = lambda kind, name: self.create_publisher(kind, name, q(name))\npub(A, c.CLOCK)",
            {"sub": set(), "pub": {t.CLOCK}},
        ),
        (
            "self.create_subscription(A, topic=c.TORQUE, callback=f)",
            {"sub": {t.TORQUE}, "pub": set()},
        ),
        (
            "for slot, (name, kind) in enumerate(((c.ATTITUDE, A), (c.TARGET_RATE, B))):\n"
            "    self.create_subscription(kind, name, cb, q)",
            {"sub": {t.ATTITUDE, t.TARGET_RATE}, "pub": set()},
        ),
        (
            "for topic in c.TOPICS:\n    self.create_subscription(X, topic.name, cb, q)",
            {"sub": TOPIC_NAMES, "pub": set()},
        ),
    ],
)
def test_endpoint_reader_resolves_the_forms_used(source, expected):
    assert endpoints(source) == expected


@pytest.mark.parametrize(
    "source",
    ["self.create_publisher(A, '/elsewhere', q)", "self.create_subscription(A, some_name, cb, q)"],
)
def test_endpoint_reader_refuses_what_it_cannot_resolve(source):
    with pytest.raises(AssertionError, match="cannot resolve"):
        endpoints(source)
