"""The parameter tables: the scenario's rows (:mod:`attitude_core.config.scenario_schema`)
and each node's (:mod:`attitude_core.config.node_parameters`), and the agreement of the
scenario loader with them: a value just outside a row's bound, written into
``scenarios/case1.yaml``, is refused naming that key."""

from __future__ import annotations

import pytest
from parameter_rows import (
    ALL_ROWS,
    CASE1,
    CASE1_ROWS,
    NODE_TABLES,
    inside_values,
    reason,
    refused_just_outside,
    row,
    with_value,
)

from attitude_core.config.node_parameters import (
    CONTROLLER,
    PLANNER,
    RECORDER,
    SIMULATOR,
    NodeParameters,
    NoParams,
)
from attitude_core.config.parameters import (
    REQUIRED,
    ROS_TYPES,
    ByVariant,
    NodeParameterError,
    convert,
    values_from,
)
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.config.scenario_schema import INSTRUMENT_PARAMETERS, SCENARIO_PARAMETERS
from attitude_core.contract.status import PlannerStatus

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
        default = param.default_for(variant)
        assert default in param.choices or (default is None and not param.required)


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


BOUNDED_ROWS = [q for q in CASE1_ROWS if q.bounds is not None]


def test_bounded_rows_include_the_closed_ones():
    closed = {q.key for q in BOUNDED_ROWS if q.bounds.closed() is not None}
    assert closed == {
        "planner.gamma_deg",
        "planner.safety_margin_deg",
        "planner.obstacle_samples",
        "planner.roadmap_nodes",
        "instruments.star_tracker.half_angle_deg",
        "orbit.eccentricity",
        "orbit.inclination_deg",
        "link.drop_rate",
        *(f"instruments.star_tracker.exclusion_deg.object_{k}" for k in (1, 2, 3)),
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
        "orbit.eccentricity": "[0, 1)",
        "orbit.inclination_deg": "[0, 180]",
        "link.drop_rate": "[0, 1)",
        **{f"instruments.star_tracker.exclusion_deg.object_{k}": "[0, 180)" for k in (1, 2, 3)},
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
    table = NodeParameters(own=(), scenario=("a", "b.*"), values=NoParams)
    assert table.reads_scenario_key("a") and table.reads_scenario_key("b.c.d")
    assert not table.reads_scenario_key("b") and not table.reads_scenario_key("ab")
    assert not NodeParameters(own=(), scenario=(), values=NoParams).reads_scenario_key("a")


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
