"""Static checks of the Foxglove layout ``docs/foxglove_layout.json`` (see ``docs/foxglove.md``).

No Foxglove here: the checks are that the file is a well-formed layout of the
``configById`` / ``layout`` (mosaic tree) kind that Foxglove's "Import layout from file"
reads, and that everything it names exists in our topic contract: every message path is
parsed with the subset of Foxglove's message path grammar the layout uses and resolved
field by field against the ROS 2 message classes (``get_fields_and_field_types``), or,
for the output of a user script embedded in the layout, against the script's declared
output type.
"""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import pytest

from attitude_core.contract import diagnostics, topics
from attitude_core.contract.faults import FaultKind
from attitude_core.contract.goals import GOAL_DIAGNOSTIC_NAME, GoalReport
from attitude_core.contract.status import DiagnosticLevel, GoalOutcome, PlannerStatus

ROOT = Path(__file__).resolve().parents[2]
LAYOUT_FILE = ROOT / "docs" / "foxglove_layout.json"

CONTRACT = {t.name: t for t in topics.TOPICS + topics.COMMAND_TOPICS}
_GOAL = GoalReport("topic", 1, "goal@1", (0.0, 0.0, 0.0), 1.0, GoalOutcome.ACCEPTED, 0.0)
GOAL_KEYS = {key for key, _ in _GOAL.diagnostic_values()}  # a goal report's /diagnostics keys
KNOWN_PANEL_TYPES = {
    "Plot",
    "StateTransitions",
    "RawMessages",
    "DiagnosticSummary",
    "DiagnosticStatusPanel",
    "3D",
    "Tab",
}
TIMESTAMP_METHODS = {"receiveTime", "headerStamp"}

# --- ROS message types ----------------------------------------------------------------

NUMERIC = {
    "boolean",
    "octet",
    "char",
    "float",
    "double",
    "long double",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
}
# Foxglove shows builtin_interfaces Time/Duration as {sec, nsec} (not ROS 2's nanosec):
# treat them as leaves (the Plot panel plots a time as seconds).
TIME_TYPES = {"builtin_interfaces/Time", "builtin_interfaces/Duration"}
_SEQUENCE = re.compile(r"sequence<([^,>]+)(?:,\s*\d+)?>$")
_ARRAY = re.compile(r"(.+)\[\d+\]$")
_BOUNDED_STRING = re.compile(r"w?string(<\d+>)?$")


def _short(type_name: str) -> str:
    """``pkg/msg/Name`` or ``pkg/Name`` -> ``pkg/Name``."""
    parts = type_name.split("/")
    return f"{parts[0]}/{parts[-1]}"


def _split_type(field_type: str) -> tuple[str, bool]:
    """A field type of ``get_fields_and_field_types`` -> (element type, is a sequence)."""
    for pattern in (_SEQUENCE, _ARRAY):
        m = pattern.match(field_type)
        if m:
            return m.group(1).strip(), True
    return field_type, False


def _kind(type_name: str) -> str:
    if type_name in NUMERIC:
        return "number"
    if _BOUNDED_STRING.match(type_name):
        return "string"
    if _short(type_name) in TIME_TYPES:
        return "time"
    return "message"


def _ros_fields(type_name: str) -> dict[str, str]:
    pkg, name = _short(type_name).split("/")
    cls = getattr(importlib.import_module(f"{pkg}.msg"), name)
    return cls.get_fields_and_field_types()


class RosType:
    """A ROS message type, walked through its Python message class."""

    def __init__(self, type_name: str):
        self.type_name = type_name

    def field(self, name: str):
        fields = _ros_fields(self.type_name)
        if name not in fields:
            raise KeyError(f"{self.type_name} has no field {name!r} (fields: {sorted(fields)})")
        element, is_sequence = _split_type(fields[name])
        kind = _kind(element)
        return (RosType(element) if kind == "message" else kind), is_sequence


class LiteralType:
    """A TypeScript object type literal of a user script, as nested dicts of field types."""

    def __init__(self, fields: dict):
        self.fields = fields

    def field(self, name: str):
        if name not in self.fields:
            raise KeyError(f"script output has no field {name!r} (fields: {sorted(self.fields)})")
        value = self.fields[name]
        if isinstance(value, dict):
            return LiteralType(value), False
        if value.endswith("[]"):
            return {"number[]": "number", "string[]": "string"}[value], True
        return {"number": "number", "string": "string", "boolean": "number"}[value], False


# --- message paths --------------------------------------------------------------------

_ID = r"[A-Za-z0-9_-]+"
_TOPIC = re.compile(rf"(?:/{_ID})+")
_ELEMENT = re.compile(
    rf"""\.(?P<name>{_ID})
         (?:\[(?P<slice>-?\d*(?::-?\d*)?)\])?
         (?:\{{(?P<fpath>{_ID}(?:\.{_ID})*)(?P<op>==|!=|>=|<=|>|<)
              (?P<fvalue>"[^"]*"|'[^']*'|-?\d+|true|false)\}})?""",
    re.VERBOSE,
)
_REFERENCE_LINE = re.compile(r"-?\d+(\.\d*)?([eE][-+]?\d+)?$")


def parse_message_path(path: str) -> tuple[str, list[dict]]:
    """``/topic.field[:]{key=="x"}.sub`` -> (topic, elements); the grammar subset used here."""
    m = _TOPIC.match(path)
    assert m, f"{path!r}: no topic name"
    topic, pos, elements = m.group(0), m.end(), []
    while pos < len(path):
        e = _ELEMENT.match(path, pos)
        assert e, f"{path!r}: cannot parse from {path[pos:]!r}"
        elements.append(e.groupdict())
        pos = e.end()
    return topic, elements


def _literal_kind(text: str) -> str:
    return "string" if text[0] in "'\"" else "number"


def resolve(root, elements: list[dict], path: str):
    """Walk ``elements`` from the message type ``root``; returns the leaf kind."""
    current, is_sequence = root, False
    for e in elements:
        assert not is_sequence, f"{path!r}: field {e['name']!r} of an array without a slice"
        assert not isinstance(current, str), f"{path!r}: {e['name']!r} below a {current} leaf"
        try:
            current, is_sequence = current.field(e["name"])
        except KeyError as err:
            pytest.fail(f"{path!r}: {err}")
        if e["slice"] is not None:
            assert is_sequence, f"{path!r}: slice on the non-array field {e['name']!r}"
            is_sequence = False
        if e["fpath"] is not None:
            assert not is_sequence and not isinstance(current, str), (
                f"{path!r}: filter must follow a slice of an array of messages"
            )
            kind = resolve(
                current,
                [{"name": n, "slice": None, "fpath": None} for n in e["fpath"].split(".")],
                path,
            )
            assert kind == _literal_kind(e["fvalue"]), (
                f"{path!r}: filter compares a {kind} field with {e['fvalue']}"
            )
    assert not is_sequence, f"{path!r} ends on an array"
    return current if isinstance(current, str) else "message"


# --- user scripts ---------------------------------------------------------------------

# The regular expression Foxglove uses for the output (UserScriptPlayer transform.ts).
_OUTPUT = re.compile(r"""^\s*export\s+const\s+output\s*=\s*("([^"]+)"|'([^']+)')""", re.M)
_INPUTS = re.compile(r"^\s*export\s+const\s+inputs\s*=\s*\[([^\]]*)\]", re.M)
_OUTPUT_TYPE = re.compile(r"^type\s+Output\s*=\s*", re.M)


def _output_type_text(source: str) -> str | None:
    """The right-hand side of ``type Output = ...;`` (braces balanced)."""
    m = _OUTPUT_TYPE.search(source)
    if not m:
        return None
    start = m.end()
    if source[start] != "{":
        return source[start : source.index(";", start)]
    depth = 0
    for i in range(start, len(source)):
        depth += {"{": 1, "}": -1}.get(source[i], 0)
        if depth == 0:
            return source[start : i + 1]
    return None


def _parse_type_literal(text: str):
    """``{ a: number; b: { c: string } }`` -> nested dict (the small subset used here)."""
    tokens = re.findall(r"[{}:;,]|[A-Za-z_][A-Za-z0-9_]*(?:\[\])?", text)
    pos = 0

    def parse_object():
        nonlocal pos
        assert tokens[pos] == "{"
        pos += 1
        fields = {}
        while tokens[pos] != "}":
            name, colon = tokens[pos], tokens[pos + 1]
            assert colon == ":", f"bad type literal near {name!r}"
            pos += 2
            if tokens[pos] == "{":
                fields[name] = parse_object()
            else:
                fields[name] = tokens[pos]
                pos += 1
            if tokens[pos] in ";,":
                pos += 1
        pos += 1
        return fields

    result = parse_object()
    assert pos == len(tokens), "trailing tokens after the type literal"
    return result


class Script:
    def __init__(self, script_id: str, node: dict):
        self.id = script_id
        self.name = node["name"]
        self.source = node["sourceCode"]
        out = _OUTPUT.search(self.source)
        assert out, f"user script {script_id}: no `export const output`"
        self.output = out.group(2) or out.group(3)
        inputs = _INPUTS.search(self.source)
        assert inputs, f"user script {script_id}: no `export const inputs = [...]`"
        self.inputs = re.findall(r"""["']([^"']+)["']""", inputs.group(1))
        text = _output_type_text(self.source)
        assert text, f"user script {script_id}: no `type Output = ...;`"
        text = text.strip()
        schema = re.fullmatch(r"""Message<\s*["']([^"']+)["']\s*>""", text)
        self.output_schema = schema.group(1) if schema else None
        self.output_type = None if schema else LiteralType(_parse_type_literal(text))


# --- the layout -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def layout() -> dict:
    return json.loads(LAYOUT_FILE.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def scripts(layout) -> dict[str, Script]:
    found = [Script(k, v) for k, v in layout["userNodes"].items()]
    by_output = {s.output: s for s in found}
    assert len(by_output) == len(found), "two user scripts publish the same output topic"
    return by_output


def panel_type(panel_id: str) -> str:
    assert "!" in panel_id, f"panel id {panel_id!r} is not of the form Type!id"
    return panel_id.split("!", 1)[0]


def mosaic_leaves(node, where="layout") -> list[str]:
    if isinstance(node, str):
        return [node]
    assert isinstance(node, dict), f"{where}: a mosaic node is a panel id or a split"
    assert set(node) <= {"first", "second", "direction", "splitPercentage"}, f"{where}: {node}"
    assert node["direction"] in ("row", "column"), f"{where}: direction {node['direction']!r}"
    if "splitPercentage" in node:
        assert 0 < node["splitPercentage"] < 100, f"{where}: splitPercentage"
    return mosaic_leaves(node["first"], where + ".first") + mosaic_leaves(
        node["second"], where + ".second"
    )


def all_panel_ids(layout) -> list[str]:
    ids = mosaic_leaves(layout["layout"])
    for panel_id in list(ids):
        if panel_type(panel_id) == "Tab":
            for tab in layout["configById"][panel_id]["tabs"]:
                if tab.get("layout") is not None:
                    ids += mosaic_leaves(tab["layout"], f"{panel_id}.{tab.get('title')}")
    return ids


def message_paths(panel_id: str, config: dict) -> list[tuple[str, str | None]]:
    """(message path, timestampMethod) of a panel; reference lines of a Plot excluded."""
    kind = panel_type(panel_id)
    if kind in ("Plot", "StateTransitions"):
        return [
            (p["value"], p["timestampMethod"])
            for p in config["paths"]
            if not _REFERENCE_LINE.match(p["value"])
        ]
    if kind == "RawMessages":
        return [(config["topicPath"], None)]
    return []


def panel_topics(panel_id: str, config: dict) -> set[str]:
    found = {parse_message_path(p)[0] for p, _ in message_paths(panel_id, config)}
    if "topicToRender" in config:
        found.add(config["topicToRender"])
    return found


def root_type(topic: str, scripts: dict[str, Script]):
    if topic in CONTRACT:
        return RosType(CONTRACT[topic].type_name)
    script = scripts[topic]
    assert script.output_type is not None, (
        f"{topic}: output of a script with a schema type, not plotted field by field here"
    )
    return script.output_type


# --- tests ----------------------------------------------------------------------------


def test_top_level_keys(layout):
    assert set(layout) >= {"configById", "layout", "globalVariables", "userNodes", "playbackConfig"}
    assert layout["playbackConfig"]["speed"] > 0
    assert isinstance(layout["globalVariables"], dict)


def test_every_panel_in_the_tree_has_a_config_and_vice_versa(layout):
    ids = all_panel_ids(layout)
    assert len(ids) == len(set(ids)), "a panel id appears twice in the layout tree"
    assert set(ids) == set(layout["configById"])


def test_panel_types_are_known(layout):
    for panel_id in layout["configById"]:
        assert panel_type(panel_id) in KNOWN_PANEL_TYPES, panel_id


def test_series_are_well_formed(layout):
    for panel_id, config in layout["configById"].items():
        if panel_type(panel_id) in ("Plot", "StateTransitions"):
            assert config["paths"], f"{panel_id} has no series"
            for p in config["paths"]:
                assert isinstance(p["value"], str) and p["value"], panel_id
                assert p["timestampMethod"] in TIMESTAMP_METHODS, (panel_id, p)
                assert p.get("enabled", True) is True, (panel_id, p)
        if panel_type(panel_id) == "Plot":
            assert config["xAxisVal"] == "timestamp", panel_id


def test_every_topic_is_a_contract_topic_or_a_script_output(layout, scripts):
    for panel_id, config in layout["configById"].items():
        for topic in panel_topics(panel_id, config):
            assert topic in CONTRACT or topic in scripts, f"{panel_id}: unknown topic {topic}"


def test_user_scripts_read_contract_topics_only(scripts):
    for script in scripts.values():
        assert script.inputs, script.id
        for topic in script.inputs:
            assert topic in CONTRACT, f"user script {script.id}: input {topic} not in the contract"
        # Foxglove's documented prefixes for script outputs (old and new).
        assert script.output.startswith(("/studio_script/", "/foxglove_script/")), script.output
        assert script.output not in CONTRACT


def test_user_scripts_read_existing_fields(scripts):
    for script in scripts.values():
        inputs = [RosType(CONTRACT[t].type_name) for t in script.inputs]
        for first, second in re.findall(r"event\.message\.(\w+)(?:\.(\w+))?", script.source):
            ok = False
            for root in inputs:
                try:
                    child, _ = root.field(first)
                    if second:
                        assert isinstance(child, RosType)
                        child.field(second)
                    ok = True
                except (KeyError, AssertionError):
                    continue
            assert ok, f"user script {script.id}: no input has event.message.{first}.{second}"


def test_every_field_path_resolves(layout, scripts):
    for panel_id, config in layout["configById"].items():
        kind = panel_type(panel_id)
        for path, _ in message_paths(panel_id, config):
            topic, elements = parse_message_path(path)
            leaf = resolve(root_type(topic, scripts), elements, path)
            if kind == "Plot":
                # Plot converts a string with +value (the diagnostics' key/value strings).
                assert leaf in ("number", "time", "string"), f"{panel_id}: {path} is a {leaf}"
            elif kind == "StateTransitions":
                assert leaf in ("number", "string"), f"{panel_id}: {path} is a {leaf}"


def _has_header_stamp(root) -> bool:
    """Whether messages of ``root`` have ``header.stamp`` as Foxglove's headerStamp wants."""
    try:
        header, _ = root.field("header")
        stamp, _ = header.field("stamp")
    except (KeyError, AttributeError):
        return False
    if stamp == "time":
        return True
    return isinstance(stamp, LiteralType) and set(stamp.fields) == {"sec", "nsec"}


def test_header_stamp_is_used_exactly_where_messages_have_a_header(layout, scripts):
    for panel_id, config in layout["configById"].items():
        for path, method in message_paths(panel_id, config):
            if method is None:
                continue
            topic, _ = parse_message_path(path)
            root = root_type(topic, scripts)
            has_header = _has_header_stamp(root)
            expected = "headerStamp" if has_header else "receiveTime"
            assert method == expected, f"{panel_id}: {path} uses {method}, expected {expected}"


def test_every_contract_topic_but_clock_is_shown(layout):
    shown = set()
    for panel_id, config in layout["configById"].items():
        shown |= panel_topics(panel_id, config)
    missing = set(CONTRACT) - {topics.CLOCK} - shown
    assert not missing, f"contract topics in no panel: {sorted(missing)}"


def test_requested_series_are_present(layout):
    values = {p["value"] for c in layout["configById"].values() for p in c.get("paths", [])}
    for topic, fields in (
        (topics.ATTITUDE, "quaternion.x quaternion.y quaternion.z quaternion.w"),
        (topics.ANGULAR_VELOCITY, "vector.x vector.y vector.z"),
        (topics.TORQUE, "wrench.torque.x wrench.torque.y wrench.torque.z"),
        (topics.TARGET_MRP, "vector.x vector.y vector.z"),
        (topics.KEEP_OUT_MARGIN, "data"),
        (topics.PLANNER_STATUS, "data"),
    ):
        for f in fields.split():
            assert f"{topic}.{f}" in values, f"{topic}.{f}"


def test_margin_plot_has_a_zero_reference_line(layout):
    for panel_id, config in layout["configById"].items():
        values = [p["value"] for p in config.get("paths", [])]
        if f"{topics.KEEP_OUT_MARGIN}.data" in values and panel_type(panel_id) == "Plot":
            assert "0" in values, f"{panel_id}: no reference line at 0"
            return
    pytest.fail("no Plot of the keep-out margin")


def test_diagnostics_names_match_the_planner(layout):
    """Filters and selections on /diagnostics name what the planner node publishes: the
    names of the diagnostics contract."""
    literals = {diagnostics.STATUS_NAME, diagnostics.HARDWARE_ID, *diagnostics.KEYS}
    literals |= {kind.diagnostic_name for kind in FaultKind}
    literals |= {GOAL_DIAGNOSTIC_NAME, *GOAL_KEYS}
    for panel_id, config in layout["configById"].items():
        for path, _ in message_paths(panel_id, config):
            topic, elements = parse_message_path(path)
            if topic != topics.DIAGNOSTICS:
                continue
            for e in elements:
                if e["fvalue"] is not None and e["fvalue"][0] in "'\"":
                    assert e["fvalue"][1:-1] in literals, f"{panel_id}: {path}"
        if panel_type(panel_id) in ("DiagnosticSummary", "DiagnosticStatusPanel"):
            assert config["topicToRender"] == topics.DIAGNOSTICS
            for key in ("selectedHardwareId", "selectedName"):
                if key in config:
                    assert config[key] in literals, f"{panel_id}: {key}"
            for pinned in config.get("pinnedIds", []):
                assert all(part in literals for part in pinned.strip("|").split("|")), pinned


def test_status_states_are_the_planner_statuses(layout):
    statuses = {s.value for s in PlannerStatus}
    panels = [
        c
        for k, c in layout["configById"].items()
        if panel_type(k) == "StateTransitions"
        and k not in ("StateTransitions!faults", "StateTransitions!goals")
    ]
    assert panels
    for config in panels:
        for p in config["paths"]:
            states = p.get("customStates", {}).get("states", [])
            assert {s["value"] for s in states} <= statuses
            if p["value"] == f"{topics.PLANNER_STATUS}.data":
                assert {s["value"] for s in states} == statuses


def test_3d_panel_frames_come_from_a_script(layout, scripts):
    frame_scripts = [
        s
        for s in scripts.values()
        if s.output_schema in ("foxglove.FrameTransform", "foxglove.FrameTransforms")
    ]
    for panel_id, config in layout["configById"].items():
        if panel_type(panel_id) != "3D":
            continue
        assert frame_scripts, f"{panel_id}: nothing publishes transforms"
        parents = {
            p for s in frame_scripts for p in re.findall(r'parent_frame_id:\s*"([^"]+)"', s.source)
        }
        children = {
            c
            for s in frame_scripts
            for c in re.findall(r'(?:child_frame_id:|child\s*=)\s*"([^"]+)"', s.source)
        }
        assert parents == {topics.INERTIAL_FRAME}
        assert children == {topics.BODY_FRAME, topics.TARGET_FRAME}
        assert config["followTf"] == topics.INERTIAL_FRAME
        for topic in config.get("topics", {}):
            assert topic in CONTRACT or topic in scripts, f"{panel_id}: {topic}"


def test_every_fault_kind_is_on_the_faults_timeline_with_its_levels(layout):
    """The faults panel shows each kind's ``/diagnostics`` status (``fdir/<kind>``) by
    level: on (its kind's level) and ended (OK), stamped."""
    config = layout["configById"]["StateTransitions!faults"]
    by_value = {p["value"]: p for p in config["paths"]}
    for kind in FaultKind:
        path = by_value[f'{topics.DIAGNOSTICS}.status[:]{{name=="{kind.diagnostic_name}"}}.level']
        assert path["timestampMethod"] == "headerStamp"
        levels = {s["value"] for s in path["customStates"]["states"]}
        assert {str(int(DiagnosticLevel.OK)), str(int(kind.level))} <= levels


WHEEL_PANEL_ENTRIES = 4  # the wheel plots show entries 0-3 of each JointState


def _plot_with(layout, value: str) -> tuple[str, dict]:
    found = [
        (k, c)
        for k, c in layout["configById"].items()
        if panel_type(k) == "Plot" and value in [p["value"] for p in c["paths"]]
    ]
    assert len(found) == 1, f"{value}: in {len(found)} Plot panels"
    return found[0]


def test_wheel_panels_plot_the_contract_joint_states(layout):
    """The wheel speeds (``/spacecraft/wheel_states`` velocity) and the motor torques,
    commanded (``/controller/wheel_torque`` effort) against applied (wheel_states effort,
    dashed), by entry 0-3, at the header stamp: contract topics of type JointState."""
    for topic in (topics.WHEEL_STATES, topics.WHEEL_TORQUE):
        assert topic in CONTRACT and topic in topics.WHEEL_TOPICS
        assert CONTRACT[topic].type_name == "sensor_msgs/msg/JointState"
    speed_id, speeds = _plot_with(layout, f"{topics.WHEEL_STATES}.velocity[0]")
    assert {p["value"] for p in speeds["paths"]} == {
        f"{topics.WHEEL_STATES}.velocity[{i}]" for i in range(WHEEL_PANEL_ENTRIES)
    }
    assert panel_topics(speed_id, speeds) == {topics.WHEEL_STATES}
    torque_id, torques = _plot_with(layout, f"{topics.WHEEL_TORQUE}.effort[0]")
    by_value = {p["value"]: p for p in torques["paths"]}
    assert set(by_value) == {
        f"{topic}.effort[{i}]"
        for topic in (topics.WHEEL_TORQUE, topics.WHEEL_STATES)
        for i in range(WHEEL_PANEL_ENTRIES)
    }
    assert panel_topics(torque_id, torques) == {topics.WHEEL_STATES, topics.WHEEL_TORQUE}
    for i in range(WHEEL_PANEL_ENTRIES):
        assert by_value[f"{topics.WHEEL_STATES}.effort[{i}]"]["lineStyle"] == "dashed"
        assert "lineStyle" not in by_value[f"{topics.WHEEL_TORQUE}.effort[{i}]"]
    for config in (speeds, torques):
        assert {p["timestampMethod"] for p in config["paths"]} == {"headerStamp"}
