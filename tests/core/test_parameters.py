"""Parameters as data: :mod:`attitude_core.config.parameters` (bounds, conversion per kind,
errors). The tables built from them (the scenario's rows, each node's, and the loader's
agreement with them) are checked in ``test_parameter_tables.py``, the optional keep-in
group in ``test_parameters_keep_in.py``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from parameter_rows import ALL_ROWS, reason, row

from attitude_core.config.parameters import (
    Bounds,
    NodeParameterError,
    Param,
    ParameterError,
    convert,
    ge,
    gt,
    values_from,
)
from attitude_core.config.scenario import ScenarioError
from attitude_core.fsw.guidance.fuzzy.files import fis_value
from attitude_core.models.mrp import dcm_from_mrp


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
    fis = p("data_file", resolve=fis_value)  # as the scenario's FIS rows
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
