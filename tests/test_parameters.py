"""Parameters as data: :mod:`attitude_core.parameters` (bounds, conversion per kind,
errors), :mod:`attitude_core.scenario_schema` (the scenario's rows) and
:mod:`attitude_core.node_parameters` (each node's own rows and the scenario keys it
reads), and the agreement of the scenario loader with its table: a value just outside
a row's bound, written into ``scenarios/case1.yaml``, is refused naming that key.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from attitude_core.mrp import dcm_from_mrp
from attitude_core.node_parameters import CONTROLLER, PLANNER, RECORDER, SIMULATOR, NodeParameters
from attitude_core.parameters import (
    REQUIRED,
    ROS_TYPES,
    Bounds,
    ByVariant,
    NodeParameterError,
    Param,
    ParameterError,
    convert,
    ge,
    gt,
    values_from,
)
from attitude_core.scenario import ScenarioError, loads_scenario, scenario_keys
from attitude_core.scenario_schema import (
    INSTRUMENT_PARAMETERS,
    KEEP_IN_PARAMETERS,
    OBJECT_PARAMETERS,
    SCENARIO_PARAMETERS,
)
from attitude_core.status import PlannerStatus

ROOT = Path(__file__).resolve().parents[1]
CASE1 = (ROOT / "scenarios" / "case1.yaml").read_text(encoding="utf-8")
NODE_TABLES = {
    "planner": PLANNER,
    "controller": CONTROLLER,
    "simulator": SIMULATOR,
    "recorder": RECORDER,
}
# Every scenario row under its dotted key, with the names of case1.yaml.
CASE1_ROWS = scenario_keys(("star_tracker",), ("object_1", "object_2", "object_3"))
ALL_ROWS = (
    list(SCENARIO_PARAMETERS)
    + list(INSTRUMENT_PARAMETERS)
    + list(OBJECT_PARAMETERS)
    + list(KEEP_IN_PARAMETERS)
    + [p for table in NODE_TABLES.values() for p in table.own]
)


def row(key: str, rows=CASE1_ROWS) -> Param:
    return next(p for p in rows if p.key == key)


def reason(param: Param, raw, **kw) -> str:
    """The reason ``convert`` refuses ``raw`` with (fails if it accepts it)."""
    with pytest.raises(ParameterError) as info:
        convert(param, raw, "src.yaml", **kw)
    assert info.value.key == param.key and info.value.source == "src.yaml"
    assert str(info.value) == f"src.yaml: {param.key}: {info.value.reason}"
    return info.value.reason


def p(kind: str, **kw) -> Param:
    return Param("group.value", kind, "a test row", **kw)


# --- Bounds ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "bounds, text",
    [
        (Bounds(0.0, 180.0, hi_open=True), "[0, 180)"),
        (Bounds(0.0, 90.0, lo_open=True, hi_open=True), "(0, 90)"),
        (Bounds(16, 100_000), "[16, 100000]"),
        (Bounds(-1.5, 2.5, lo_open=True), "(-1.5, 2.5]"),
        (gt(0.0), "> 0"),
        (ge(0.0), ">= 0"),
        (Bounds(hi=5.0), "<= 5"),
        (Bounds(hi=5.0, hi_open=True), "< 5"),
    ],
)
def test_bounds_text(bounds, text):
    assert bounds.text() == text


@pytest.mark.parametrize(
    "bounds, x, message",
    [
        (Bounds(0.0, 180.0, hi_open=True), 180.0, "must be in [0, 180), got 180.0"),
        (Bounds(0.0, 180.0, hi_open=True), -1e-9, "must be in [0, 180), got -1e-09"),
        (Bounds(0.0, 90.0, lo_open=True, hi_open=True), 0.0, "must be in (0, 90), got 0.0"),
        (Bounds(16, 100_000), 15, "must be in [16, 100000], got 15"),
        (Bounds(16, 100_000), 100_001, "must be in [16, 100000], got 100001"),
        (gt(0.0), 0.0, "must be > 0, got 0.0"),
        (ge(0.0), -1.0, "must be >= 0, got -1.0"),
        (Bounds(hi=5.0), 5.5, "must be <= 5, got 5.5"),
        (Bounds(hi=5.0, hi_open=True), 5.0, "must be < 5, got 5.0"),
    ],
)
def test_bounds_check_refuses_with_its_text(bounds, x, message):
    assert bounds.check(x) == message


@pytest.mark.parametrize(
    "bounds, inside",
    [
        (Bounds(0.0, 180.0, hi_open=True), [0.0, 179.999, math.nextafter(180.0, 0.0)]),
        (Bounds(0.0, 90.0, lo_open=True, hi_open=True), [5e-324, 45.0, math.nextafter(90.0, 0.0)]),
        (Bounds(16, 100_000), [16, 100_000]),
        (gt(0.0), [5e-324, 1e300]),
        (ge(0.0), [0.0, -0.0, 1.0]),
        (Bounds(hi=5.0), [5.0, -1e300]),
        (Bounds(hi=5.0, hi_open=True), [math.nextafter(5.0, 0.0)]),
        (Bounds(), [-1e300, 0.0, 1e300]),
    ],
)
def test_bounds_check_accepts_inside(bounds, inside):
    for x in inside:
        assert bounds.check(x) is None, x


def test_bounds_closed_only_when_both_sides_bounded():
    assert Bounds(0.0, 180.0, hi_open=True).closed() == (0.0, 180.0)
    assert Bounds(16, 100_000).closed() == (16, 100_000)
    assert gt(0.0).closed() is None
    assert ge(0.0).closed() is None
    assert Bounds(hi=5.0).closed() is None


def test_unbounded_bounds_have_a_text():
    assert Bounds().text() == "any value"
    assert Bounds().check(-1e300) is None


def test_bound_text_of_integer_rows_is_integers():
    for param in ALL_ROWS:
        if param.kind == "int" and param.bounds is not None:
            assert re.fullmatch(r"[\[(]-?\d+, -?\d+[\])]|[<>]=? -?\d+", param.bounds.text()), (
                param.key,
                param.bounds.text(),
            )


# --- convert() per kind -----------------------------------------------------------------


def test_float_accepts_a_float():
    value = convert(p("float"), 2.5, "src.yaml")
    assert value == 2.5 and type(value) is float


@pytest.mark.parametrize(
    "raw, message",
    [
        (
            10,
            "expected float, got integer 10; write it as a YAML float, e.g. 10.0 "
            "(ROS 2 parameters are strongly typed)",
        ),
        (
            0,
            "expected float, got integer 0; write it as a YAML float, e.g. 0.0 "
            "(ROS 2 parameters are strongly typed)",
        ),
        ("1.5", "expected float, got string '1.5'; write it as a YAML float, e.g. 1.5"),
        ("fast", "expected float, got string 'fast'"),
        (True, "expected float, got boolean True"),
        (None, "expected float, got null None"),
        ([1.0], "expected float, got list [1.0]"),
        (float("nan"), "must be finite, got nan"),
        (float("inf"), "must be finite, got inf"),
        (float("-inf"), "must be finite, got -inf"),
    ],
)
def test_float_is_strict(raw, message):
    assert reason(p("float"), raw) == message


def test_float_too_large_int_has_no_float_hint():
    got = reason(p("float"), 10**400)
    assert got.startswith("expected float, got integer 1000") and "YAML float" not in got


def test_float_bounds_apply_after_conversion():
    assert reason(p("float", bounds=gt(0.0)), 0.0) == "must be > 0, got 0.0"
    assert reason(p("float", bounds=gt(0.0)), 0).startswith("expected float")


@pytest.mark.parametrize(
    "raw, message",
    [
        (1.0, "expected integer, got float 1.0"),
        (True, "expected integer, got boolean True"),
        ("3", "expected integer, got string '3'"),
    ],
)
def test_int_is_strict(raw, message):
    assert reason(p("int"), raw) == message
    assert convert(p("int"), 3, "src.yaml") == 3


@pytest.mark.parametrize(
    "raw, message",
    [
        (1, "expected boolean, got integer 1"),
        ("true", "expected boolean, got string 'true'"),
        (None, "expected boolean, got null None"),
    ],
)
def test_bool_is_strict(raw, message):
    assert reason(p("bool"), raw) == message
    assert convert(p("bool"), True, "src.yaml") is True
    assert convert(p("bool"), False, "src.yaml") is False


def test_vec3_and_matrix3():
    np.testing.assert_array_equal(convert(p("vec3"), [1.0, -2.0, 3.5], "s"), [1.0, -2.0, 3.5])
    m = convert(p("matrix3"), [float(k) for k in range(9)], "s")
    np.testing.assert_array_equal(m, np.arange(9.0).reshape(3, 3))
    assert reason(p("vec3"), [1.0, 2.0]) == "expected a list of 3 floats, got 2 elements"
    assert reason(p("vec3"), (1.0, 2.0, 3.0)).startswith("expected a list of 3 floats, got tuple")
    assert reason(p("vec3"), [1.0, 0, 3.0]).startswith("element 1: expected float, got integer 0")
    assert reason(p("vec3"), [1.0, 2.0, math.nan]) == "element 2: must be finite, got nan"
    assert reason(p("matrix3"), [0.0] * 8) == "expected a list of 9 floats, got 8 elements"


@pytest.mark.parametrize(
    "raw", [[1.04, 0.0, 0.0], [0.0, -0.96, 0.0], [0.0, -0.981, -0.196], [0.6, 0.8, 0.02]]
)
def test_unit3_normalises_within_five_percent(raw):
    u = convert(p("unit3"), raw, "s")
    assert abs(np.linalg.norm(u) - 1.0) < 1e-15
    np.testing.assert_allclose(u, np.array(raw) / np.linalg.norm(raw), rtol=0, atol=1e-16)


@pytest.mark.parametrize(
    "raw, norm",
    [([1.06, 0.0, 0.0], "1.06"), ([0.0, 0.94, 0.0], "0.94"), ([1.0, 1.0, 0.0], "1.414")],
)
def test_unit3_refuses_a_norm_off_by_more_than_five_percent(raw, norm):
    assert reason(p("unit3"), raw) == (
        f"must be a unit vector (norm within 5% of 1), got norm {norm}"
    )


def test_unit3_refuses_zero():
    assert reason(p("unit3"), [0.0, 0.0, 0.0]) == "must be a non-zero vector"


def test_mrp_longer_than_one_is_taken_as_its_shadow_set():
    sigma = np.array([0.6, 0.8, 0.6])  # |sigma|^2 = 1.36
    value = convert(p("mrp"), sigma.tolist(), "s")
    np.testing.assert_allclose(value, -sigma / 1.36, rtol=0, atol=1e-16)
    assert np.linalg.norm(value) <= 1.0
    np.testing.assert_allclose(dcm_from_mrp(value), dcm_from_mrp(sigma), atol=1e-14)
    np.testing.assert_array_equal(convert(p("mrp"), [0.0, 0.0, 2.0], "s"), [0.0, 0.0, -0.5])
    for kept in ([0.1, -0.2, 0.3], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]):
        np.testing.assert_array_equal(convert(p("mrp"), kept, "s"), kept)


def test_names():
    assert convert(p("names"), ["a", "b_2", "Cam"], "s") == ("a", "b_2", "Cam")
    assert reason(p("names"), ["a", "b", "a", "b", "c"]) == "duplicate names ['a', 'b']"
    assert reason(p("names"), []) == "expected a non-empty list of names, got list []"
    assert reason(p("names"), "a") == "expected a non-empty list of names, got string 'a'"
    assert reason(p("names"), ["2nd"]) == "invalid name '2nd': must match [A-Za-z][A-Za-z0-9_]*"
    assert reason(p("names"), ["a-b"]).startswith("invalid name 'a-b'")


def test_name_and_str():
    assert convert(p("name"), "case1", "s") == "case1"
    assert reason(p("name"), "case 1").startswith("invalid name 'case 1'")
    assert reason(p("name"), "_x").startswith("invalid name '_x'")
    assert reason(p("str"), 3) == "expected string, got integer 3"
    assert convert(p("path"), "out/dir", "s") == "out/dir"


def test_str_list():
    assert convert(p("str_list"), ["a", "", "b c"], "s") == ("a", "", "b c")
    assert convert(p("str_list"), [], "s") == ()
    assert reason(p("str_list"), "a") == "expected a list of strings, got string 'a'"
    assert reason(p("str_list"), ["a", 1]) == "expected string, got integer 1"


def test_data_file(tmp_path):
    fis = p("data_file")
    assert convert(fis, "fis_attractive.yaml", "s") == "fis_attractive.yaml"  # packaged
    assert reason(fis, "no_such_fis.yaml").startswith(
        "'no_such_fis.yaml' is not a packaged FIS file"
    )
    assert reason(fis, "") == "must be a non-empty string"
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "fis.yaml").write_text("{}\n")
    assert convert(fis, "mine/fis.yaml", "s", base_dir=tmp_path) == str(
        (tmp_path / "mine" / "fis.yaml").resolve()
    )
    assert reason(fis, "mine/other.yaml", base_dir=tmp_path).endswith("does not exist")


def test_choices():
    param = p("str", choices=("improved", "paper"))
    assert convert(param, "paper", "s") == "paper"
    assert reason(param, "Paper") == "must be one of ['improved', 'paper'], got 'Paper'"


def test_check_runs_after_the_type_and_bounds():
    calls = []

    def positive_sum(v):
        calls.append(v)
        return None if sum(v) > 0 else f"sum must be > 0, got {float(sum(v))!r}"

    param = p("vec3", check=positive_sum)
    assert reason(param, [-1.0, 0.5, 0.25]) == "sum must be > 0, got -0.25"
    assert reason(param, [1, 0.5, 0.25]).startswith("element 0: expected float")
    assert len(calls) == 1  # not called on a type error
    bounded = p("float", bounds=ge(0.0), check=lambda v: "never")
    assert reason(bounded, -1.0) == "must be >= 0, got -1.0"  # the bound is reported first
    assert reason(bounded, 1.0) == "never"


def test_inertia_row_refuses_non_physical_bodies():
    inertia = row("inertia_kgm2")
    assert "must be symmetric" in reason(inertia, [10.0, 1.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0])
    assert "must be positive definite" in reason(
        inertia, [10.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 10.0]
    )
    assert "triangle inequality" in reason(inertia, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 3.0])
    j = convert(inertia, [10.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0], "s")
    np.testing.assert_array_equal(j, 10.0 * np.eye(3))


def test_error_class_is_honoured():
    with pytest.raises(ScenarioError) as info:
        convert(p("int"), 1.5, "f.yaml", error=ScenarioError)
    assert (info.value.source, info.value.key) == ("f.yaml", "group.value")
    assert info.value.reason == "expected integer, got float 1.5"
    with pytest.raises(NodeParameterError):
        convert(p("int"), 1.5, "node", error=NodeParameterError)


def test_parameter_error_without_key():
    e = ParameterError("f.yaml", None, "file is empty")
    assert str(e) == "f.yaml: file is empty" and e.key is None


def test_error_classes_are_parameter_errors():
    assert issubclass(ScenarioError, ParameterError)
    assert issubclass(NodeParameterError, ParameterError)
    assert issubclass(ParameterError, ValueError)
    assert not issubclass(ScenarioError, NodeParameterError)
    assert not issubclass(NodeParameterError, ScenarioError)


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="parameter x: unknown kind 'double'"):
        Param("x", "double", "d")


def test_values_from_defaults_required_and_error_class():
    rows = (Param("a", "float", "d", 1.5), Param("b", "int", "d"), Param("c", "str", "d", "x"))
    assert values_from(rows, {"b": 2}, "node") == {"a": 1.5, "b": 2, "c": "x"}
    assert values_from(rows, {"a": 3.0, "b": 2, "c": "y"}, "node") == {"a": 3.0, "b": 2, "c": "y"}
    with pytest.raises(NodeParameterError) as info:
        values_from(rows, {}, "node")
    assert (info.value.key, info.value.reason) == ("b", "missing required parameter")
    with pytest.raises(NodeParameterError) as info:
        values_from(rows, {"b": 2.0}, "node")
    assert info.value.key == "b"
    with pytest.raises(ScenarioError):
        values_from(rows, {"b": "2"}, "node", error=ScenarioError)


# --- the tables -------------------------------------------------------------------------


def test_every_scenario_row_has_a_description_and_a_ros_type():
    assert len(CASE1_ROWS) == len({q.key for q in CASE1_ROWS})
    for param in CASE1_ROWS:
        assert param.description.strip(), param.key
        assert param.ros_type == ROS_TYPES[param.kind]
        assert param.ros_type in {
            "string",
            "string_array",
            "integer",
            "double",
            "bool",
            "double_array",
        }


@pytest.mark.parametrize("param", ALL_ROWS, ids=lambda q: q.key)
def test_bounds_are_on_numbers_and_shown_in_the_description(param):
    if param.bounds is None:
        return
    assert param.kind in ("int", "float"), param.key
    assert param.rule == param.bounds.text()
    assert param.full_description == f"{param.description} ({param.bounds.text()})"
    optional = param.default is None  # absent means off (e.g. no actuator bound)
    if not param.required and not optional and not isinstance(param.default, ByVariant):
        assert param.bounds.check(param.default) is None  # the default is in bounds


@pytest.mark.parametrize("param", [q for q in ALL_ROWS if q.choices], ids=lambda q: q.key)
def test_choices_are_shown_in_the_description(param):
    assert param.full_description.endswith(f"(one of {', '.join(param.choices)})")
    for variant in ("improved", "paper"):
        assert param.default_for(variant) in param.choices


def test_rows_without_a_rule_show_the_bare_description():
    name = row("scenario_name")
    assert name.rule is None and name.full_description == name.description


@pytest.mark.parametrize(
    "param",
    [q for q in SCENARIO_PARAMETERS if isinstance(q.default, ByVariant)],
    ids=lambda q: q.key,
)
def test_by_variant_defaults_resolve_and_are_valid(param):
    assert param.default_for("improved") == param.default.improved
    assert param.default_for("paper") == param.default.paper
    for variant in ("improved", "paper"):
        value = param.default_for(variant)
        assert convert(param, value, "defaults") == value


def test_by_variant_only_on_planner_rows_and_plain_defaults_ignore_the_variant():
    for param in SCENARIO_PARAMETERS:
        if isinstance(param.default, ByVariant):
            assert param.key.startswith("planner.") and param.key != "planner.variant"
        else:
            assert param.default_for("improved") is param.default_for("paper")
    assert row("controller.kp_over_j").default_for("paper") == 5.5
    assert row("scenario_name").default_for("paper") is REQUIRED


@pytest.mark.parametrize("variant", ["improved", "paper"])
def test_the_loader_applies_the_variant_defaults(variant):
    sc = loads_scenario(CASE1 + f"    planner:\n      variant: {variant}\n")
    assert sc.planner.variant == variant
    for param in SCENARIO_PARAMETERS:
        if param.key.startswith("planner.") and param.key != "planner.variant":
            assert getattr(sc.planner, param.key.split(".", 1)[1]) == param.default_for(variant)
    # A key given explicitly overrides the variant's default.
    sc = loads_scenario(CASE1 + f"    planner:\n      variant: {variant}\n      gamma_deg: 33.0\n")
    assert sc.planner.gamma_deg == 33.0


def test_renamed_keeps_the_row():
    half = INSTRUMENT_PARAMETERS[1].renamed("instruments.cam.half_angle_deg")
    assert half.key == "instruments.cam.half_angle_deg"
    assert (half.kind, half.bounds, half.description) == (
        "float",
        INSTRUMENT_PARAMETERS[1].bounds,
        INSTRUMENT_PARAMETERS[1].description,
    )


# --- the loader agrees with the table: values just outside each bound ---------------------


def yaml_number(x: float | int) -> str:
    """``x`` as YAML 1.1 text that reads back as exactly ``x`` with its type."""
    text = repr(x)
    if isinstance(x, float) and "e" in text and "." not in text:
        text = text.replace("e", ".0e")
    assert yaml.safe_load(text) == x and type(yaml.safe_load(text)) is type(x)
    return text


def with_value(text: str, key: str, value: float | int) -> str:
    """case1.yaml with ``key`` set to ``value``: the line of the key replaced, or a dotted
    key added under ``ros__parameters``."""
    leaf = key.rsplit(".", 1)[-1]
    pattern = re.compile(rf"^(\s*{re.escape(leaf)}:\s*)[^#\n]*?(\s*(#.*)?)$", re.MULTILINE)
    matches = pattern.findall(text)
    assert len(matches) <= 1, key
    if matches:
        return pattern.sub(lambda m: m.group(1) + yaml_number(value) + m.group(2), text)
    assert not re.search(rf"^\s*{re.escape(key.split('.')[0])}:", text, re.MULTILINE), key
    return text + f"    {key}: {yaml_number(value)}\n"


def outside_values(param: Param) -> list[float | int]:
    """The values just outside each bounded side of the row's bounds."""
    b = param.bounds
    out = []
    if param.kind == "int":
        if b.lo is not None:
            out.append(b.lo if b.lo_open else b.lo - 1)
        if b.hi is not None:
            out.append(b.hi if b.hi_open else b.hi + 1)
    else:
        if b.lo is not None:
            out.append(float(b.lo) if b.lo_open else math.nextafter(b.lo, -math.inf))
        if b.hi is not None:
            out.append(float(b.hi) if b.hi_open else math.nextafter(b.hi, math.inf))
    return out


def inside_values(param: Param) -> list[float | int]:
    b = param.bounds
    if param.kind == "int":
        return [
            v
            for v in (
                (b.lo + 1 if b.lo_open else b.lo) if b.lo is not None else None,
                (b.hi - 1 if b.hi_open else b.hi) if b.hi is not None else None,
            )
            if v is not None
        ]
    return [
        v
        for v in (
            (math.nextafter(b.lo, math.inf) if b.lo_open else float(b.lo))
            if b.lo is not None
            else None,
            (math.nextafter(b.hi, -math.inf) if b.hi_open else float(b.hi))
            if b.hi is not None
            else None,
        )
        if v is not None
    ]


BOUNDED_ROWS = [q for q in CASE1_ROWS if q.bounds is not None]


def test_bounded_rows_include_the_closed_ones():
    closed = {q.key for q in BOUNDED_ROWS if q.bounds.closed() is not None}
    assert closed == {
        "planner.gamma_deg",
        "planner.safety_margin_deg",
        "planner.obstacle_samples",
        "planner.roadmap_nodes",
        "instruments.star_tracker.half_angle_deg",
    }


def test_documented_rules_of_the_angle_and_sample_rows():
    """The bounds the paper's geometry needs: a rotation angle in [0, 180) deg, a cone
    half-angle strictly inside (0, 90) deg, a positive step and time."""
    assert {q.key: q.rule for q in BOUNDED_ROWS if q.bounds.closed() is not None} == {
        "planner.gamma_deg": "[0, 180)",
        "planner.safety_margin_deg": "[0, 45)",
        "planner.obstacle_samples": "[16, 100000]",
        "planner.roadmap_nodes": "[256, 262144]",
        "instruments.star_tracker.half_angle_deg": "(0, 90)",
    }
    assert row("dt_s").rule == row("sim_time_s").rule == "> 0"
    assert row("planner.max_accel_mrp_s2").rule == ">= 0"


def test_case1_loads_unedited():
    assert loads_scenario(CASE1).name == "case1"


def test_with_value_edits_the_key():
    sc = loads_scenario(with_value(CASE1, "instruments.star_tracker.half_angle_deg", 21.5))
    assert sc.half_angles_deg.tolist() == [21.5]
    sc = loads_scenario(with_value(CASE1, "planner.obstacle_samples", 17))
    assert sc.planner.obstacle_samples == 17


def refused_just_outside(text: str, source: str, param) -> None:
    """Every value just outside ``param``'s bound, in the scenario ``text``, is refused
    naming the key and the bound's reason."""
    for value in outside_values(param):
        with pytest.raises(ScenarioError) as info:
            loads_scenario(with_value(text, param.key, value), source)
        assert info.value.key == param.key, (value, str(info.value))
        assert info.value.reason == param.bounds.check(value)
        assert str(info.value) == f"{source}: {param.key}: {param.bounds.check(value)}"


@pytest.mark.parametrize("param", BOUNDED_ROWS, ids=lambda q: q.key)
def test_loader_refuses_a_value_just_outside_the_bound(param):
    refused_just_outside(CASE1, "case1.yaml", param)


@pytest.mark.parametrize("param", BOUNDED_ROWS, ids=lambda q: q.key)
def test_loader_does_not_refuse_the_key_just_inside_the_bound(param):
    for value in inside_values(param):
        try:
            loads_scenario(with_value(CASE1, param.key, value))
        except ScenarioError as exc:  # another rule, e.g. dt_s = 5e-324: too many steps
            assert exc.key != param.key or param.bounds.text() not in exc.reason, str(exc)


# --- node tables ------------------------------------------------------------------------


def test_reads_scenario_key_wildcards():
    assert PLANNER.reads_scenario_key("planner.gamma_deg")
    assert PLANNER.reads_scenario_key("instruments.names")
    assert PLANNER.reads_scenario_key("instruments.star_tracker.half_angle_deg")
    assert PLANNER.reads_scenario_key("bright_objects.object_1.direction_inertial")
    assert PLANNER.reads_scenario_key("desired_mrp")
    assert not PLANNER.reads_scenario_key("planner")  # the group, not a key
    assert not PLANNER.reads_scenario_key("plannerx.gamma_deg")  # no prefix match
    assert not PLANNER.reads_scenario_key("controller.kp_over_j")
    assert not PLANNER.reads_scenario_key("initial_mrp")
    assert CONTROLLER.reads_scenario_key("controller.kd_over_j")
    assert not CONTROLLER.reads_scenario_key("planner.variant")
    assert SIMULATOR.reads_scenario_key("dt_s")
    assert not SIMULATOR.reads_scenario_key("dt_s.extra")  # exact key, no wildcard
    assert not SIMULATOR.reads_scenario_key("desired_mrp")
    for key in (q.key for q in CASE1_ROWS):
        assert not RECORDER.reads_scenario_key(key)  # takes no scenario


def test_reads_scenario_key_custom_table():
    table = NodeParameters(own=(), scenario=("a", "b.*"))
    assert table.reads_scenario_key("a") and table.reads_scenario_key("b.c.d")
    assert not table.reads_scenario_key("b") and not table.reads_scenario_key("ab")
    assert not NodeParameters(own=(), scenario=()).reads_scenario_key("a")


@pytest.mark.parametrize("role", ["planner", "controller", "simulator"])
def test_node_scenario_patterns_name_real_scenario_keys(role):
    table = NODE_TABLES[role]
    keys = [q.key for q in CASE1_ROWS]
    for pattern in table.scenario:
        if pattern.endswith(".*"):
            assert any(k.startswith(pattern[:-1]) for k in keys), pattern
        else:
            assert pattern in keys, pattern
    own = {q.key for q in table.own}
    assert not own & set(keys), own & set(keys)  # own rows are not scenario


def test_each_node_reads_what_it_needs():
    assert all(
        SIMULATOR.reads_scenario_key(k)
        for k in ("sim_time_s", "dt_s", "inertia_kgm2", "initial_mrp", "initial_rate_rad_s")
    )
    assert all(
        CONTROLLER.reads_scenario_key(k)
        for k in ("inertia_kgm2", "controller.kp_over_j", "controller.kd_over_j")
    )
    assert all(
        PLANNER.reads_scenario_key(q.key)
        for q in CASE1_ROWS
        if q.key.split(".")[0] in ("planner", "instruments", "bright_objects")
    )


def test_node_own_defaults_are_valid_values():
    for table in (CONTROLLER, SIMULATOR):
        values = values_from(table.own, {}, "test")
        for param in table.own:
            assert convert(param, values[param.key], "test") == values[param.key]


def test_simulator_time_mode_and_bounds():
    rows = SIMULATOR.own
    with pytest.raises(NodeParameterError) as info:
        values_from(rows, {"time_mode": "wallclock"}, "sim")
    assert (info.value.key, info.value.reason) == (
        "time_mode",
        "must be one of ['lockstep', 'realtime'], got 'wallclock'",
    )
    with pytest.raises(NodeParameterError) as info:
        values_from(rows, {"lockstep.expected_subscribers": 0}, "sim")
    assert info.value.key == "lockstep.expected_subscribers"
    with pytest.raises(NodeParameterError) as info:
        values_from(rows, {"lockstep.torque_timeout_s": 2}, "sim")
    assert "write it as a YAML float, e.g. 2.0" in info.value.reason


def test_controller_drop_fraction_bounds():
    with pytest.raises(NodeParameterError) as info:
        values_from(CONTROLLER.own, {"fault.drop_torque_fraction": 0.95}, "ctl")
    assert info.value.reason == "must be in [0, 0.9], got 0.95"


def test_recorder_stop_status_row_refuses_a_non_status_name():
    stop = row("stop_on_planner_status", RECORDER.own)
    statuses = [s.value for s in PlannerStatus]
    arrived, stuck = PlannerStatus.ARRIVED.value, PlannerStatus.STUCK.value
    assert convert(stop, [arrived, stuck], "rec") == (arrived, stuck)
    assert convert(stop, [""], "rec") == ("",)  # the default: no stop
    assert convert(stop, [], "rec") == ()
    assert stop.default == ("",)
    assert reason(stop, [arrived, "landed"]) == f"'landed' is not a planner status {statuses}"
    assert reason(stop, ["ARRIVED"]) == f"'ARRIVED' is not a planner status {statuses}"
    assert reason(stop, arrived) == f"expected a list of strings, got string {arrived!r}"
    with pytest.raises(NodeParameterError):
        values_from(RECORDER.own, {"stop_on_planner_status": ["bogus"], "output_dir": "x"}, "r")


def test_recorder_output_dir_is_required():
    with pytest.raises(NodeParameterError) as info:
        values_from(RECORDER.own, {}, "rec")
    assert (info.value.key, info.value.reason) == ("output_dir", "missing required parameter")


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
        "keep_in.sun_sensor.direction_inertial": ("unit3", True),
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
# real nodes are declared over DDS in test_node_shells.py.


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
    from attitude_core.scenario import flatten_parameters

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
    assert sc is None and own["output_dir"] == "bag"
    overrides["keep_inn.names"] = ["sun_sensor"]  # not a scenario group: a typo, refused
    with pytest.raises(NodeParameterError) as info:
        declare_node_parameters(StandInNode(overrides), RECORDER)
    assert info.value.key == "keep_inn.names"
