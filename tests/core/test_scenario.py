"""Scenario loader (attitude_core.config.scenario) and the scenario files in scenarios/."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from scenario_params import _base_params, _dump

from attitude_core.config.scenario import ArrivalConfig, PlannerConfig, ScenarioError
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import load_scenario, parse_scenario
from attitude_core.models.mrp import shadow

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / 'scenarios'
SCENARIO_FILES = sorted(SCENARIOS.glob('*.yaml'))
PAPER_CASES = {'case1', 'case2', 'case1_paper', 'case2_paper'}
OWN = {'boresight_z', 'two_instruments', 'four_objects', 'large_slew'}
TABLE1_SIGMAS = {  # paper Table 1: (sigma_0, sigma_d)
    1: ([0.0, 0.0, 0.25], [0.0, -0.2, -0.7]),
    2: ([0.3, 0.25, 0.0], [0.1, -0.3, 0.0]),
}
TABLE1_C = np.array([[0.0, -0.981, -0.196], [-1.0, 0.0, 0.0], [0.958, 0.0, 0.287]])


# --- the paper's cases ----------------------------------------------------------------


@pytest.mark.parametrize('case', [1, 2])
@pytest.mark.parametrize('suffix', ['', '_paper'])
def test_paper_cases_match_table1(case, suffix):
    sc = load_scenario(SCENARIOS / f'case{case}{suffix}.yaml')
    j = np.diag([10.0, 10.0, 10.0])
    assert sc.name == f'case{case}{suffix}'
    assert sc.sim_time_s == 150.0 and sc.dt_s == 0.1 and sc.n_steps == 1500
    np.testing.assert_array_equal(sc.inertia_kgm2, j)
    np.testing.assert_array_equal(sc.initial_mrp, TABLE1_SIGMAS[case][0])
    np.testing.assert_array_equal(sc.desired_mrp, TABLE1_SIGMAS[case][1])
    np.testing.assert_array_equal(sc.initial_rate_rad_s, np.zeros(3))
    assert sc.instrument_names == ('star_tracker',)
    np.testing.assert_array_equal(sc.boresights_body, [[1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(sc.half_angles_deg, [20.0])
    assert sc.bright_object_names == ('object_1', 'object_2', 'object_3')
    np.testing.assert_allclose(
        sc.directions_inertial,
        TABLE1_C / np.linalg.norm(TABLE1_C, axis=1, keepdims=True),
        rtol=0,
        atol=1e-15,
    )
    assert sc.kp_over_j == 5.5 and sc.kd_over_j == 3.1
    np.testing.assert_allclose(sc.kp, 5.5 * j)
    np.testing.assert_allclose(sc.kd, 3.1 * j)
    variant = 'paper' if suffix else 'improved'
    assert sc.planner.variant == variant
    assert sc.planner.direction_axis == ('paper' if suffix else 'goal_plane')
    assert sc.planner.max_accel_mrp_s2 == (0.0 if suffix else 0.01)
    assert sc.planner.terminal_time_constant_s == (0.0 if suffix else 2.0)
    assert sc.planner.fis_attractive == f'fis_attractive{suffix}.yaml'
    assert sc.planner.fis_repulsive == f'fis_repulsive{suffix}.yaml'
    assert sc.arrival == ArrivalConfig(0.5, 1.0e-3)


def test_all_scenario_files_present():
    names = {p.stem for p in SCENARIO_FILES}
    assert names >= PAPER_CASES | OWN


# --- every scenario file --------------------------------------------------------------


def _straight_line_min_margin(sc, n=2001):
    t = np.linspace(0.0, 1.0, n)[:, None]
    path = sc.initial_mrp + t * (sc.desired_mrp - sc.initial_mrp)
    return float(sc.cone_geometry().min_margin_deg(path).min())


OPERATED = {'case1_operator'}  # commanded at run time (attitude-run --until-stopped)
NEAR_GOAL = {'leo_goal_near_sun': 1.0}  # a goal deliberately this near a keep-out, deg


@pytest.mark.parametrize('path', SCENARIO_FILES, ids=lambda p: p.stem)
def test_scenario_file_loads_and_is_feasible(path):
    sc = load_scenario(path)
    assert sc.name == path.stem
    geometry = sc.cone_geometry()
    need = 0.0 if path.stem in PAPER_CASES else 5.0
    for sigma in (sc.initial_mrp, sc.desired_mrp):
        margin = float(geometry.min_margin_deg(sigma))
        near = sigma is sc.desired_mrp and path.stem in NEAR_GOAL
        assert margin > 0.0 and margin >= (NEAR_GOAL.get(path.stem, need) if near else need)
    if path.stem in OPERATED:  # holds its start until an operator sends goals
        np.testing.assert_array_equal(sc.initial_mrp, sc.desired_mrp)
    elif path.stem not in PAPER_CASES | set(NEAR_GOAL):  # near: the goal is the point
        # Constrained: the straight MRP line from start to goal crosses a keep-out cone.
        assert _straight_line_min_margin(sc) < 0.0


def test_own_scenarios_cover_the_requested_features():
    sc = {name: load_scenario(SCENARIOS / f'{name}.yaml') for name in OWN}
    assert not np.allclose(sc['boresight_z'].boresights_body[0], [1.0, 0.0, 0.0])
    two = sc['two_instruments']
    assert len(two.instrument_names) == 2
    assert len(set(two.half_angles_deg)) == 2
    assert not np.allclose(two.boresights_body[0], two.boresights_body[1])
    assert len(sc['four_objects'].bright_object_names) >= 4
    assert 0.83 <= np.linalg.norm(sc['large_slew'].desired_mrp) <= 0.87
    assert sc['large_slew'].sim_time_s >= 250.0
    for s in sc.values():
        assert np.all((s.half_angles_deg >= 15.0) & (s.half_angles_deg <= 25.0))


def _sequences(node):
    if isinstance(node, dict):
        for v in node.values():
            yield from _sequences(v)
    elif isinstance(node, list):
        yield node


@pytest.mark.parametrize('path', SCENARIO_FILES, ids=lambda p: p.stem)
def test_scenario_file_is_a_ros2_params_file(path):
    doc = yaml.safe_load(path.read_text())
    assert list(doc) == ['/**'] and list(doc['/**']) == ['ros__parameters']
    for seq in _sequences(doc):
        # rcl rejects empty arrays, nested arrays and arrays mixing types (bool != int).
        assert seq, f'empty sequence in {path.name}'
        types = {type(x) for x in seq}
        assert len(types) == 1 and types <= {bool, int, float, str}, (path.name, seq)
    flat = flatten_parameters(doc['/**']['ros__parameters'])
    assert all(isinstance(v, (bool, int, float, str, list)) for v in flat.values())


# --- API details ----------------------------------------------------------------------


def test_arrays_are_read_only():
    sc = load_scenario(SCENARIOS / 'case1.yaml')
    for a in (
        sc.inertia_kgm2,
        sc.initial_mrp,
        sc.desired_mrp,
        sc.initial_rate_rad_s,
        sc.boresights_body,
        sc.half_angles_deg,
        sc.directions_inertial,
        sc.kp,
        sc.kd,
    ):
        with pytest.raises(ValueError):
            a[0] = 1.0


def test_keep_out_uses_planner_samples_and_inflation():
    sc = load_scenario(SCENARIOS / 'case1.yaml')
    g = sc.cone_geometry(inflation_deg=2.0)
    assert g.samples == sc.planner.obstacle_samples == 180
    assert g.inflation_deg == 2.0
    assert sc.cone_geometry(samples=32).samples == 32


def test_parse_scenario_accepts_nested_and_dotted_names():
    nested = parse_scenario(_base_params())
    flat = parse_scenario(flatten_parameters(_base_params()))
    assert flatten_parameters({'a': {'b': 1, 'c': {'d': 'x'}}, 'e': 2.0}) == {
        'a.b': 1,
        'a.c.d': 'x',
        'e': 2.0,
    }
    np.testing.assert_array_equal(nested.desired_mrp, flat.desired_mrp)
    assert (
        nested.planner
        == flat.planner
        == PlannerConfig(
            'improved',
            'goal_plane',
            60.0,
            'fis_attractive.yaml',
            'fis_repulsive.yaml',
            0.03,
            0.03,
            0.3,
            2.0,
            0.01,
            2.0,
            1.0e-4,
            10.0,
            180,
            'target',
            True,
            4096,
        )
    )
    assert nested.source == '<dict>'


def test_ros_builtin_parameters_are_ignored():
    params = _base_params()
    params.update({'use_sim_time': True, 'start_type_description_service': True})
    assert parse_scenario(params).name == 'base'
    params['use_sim_time'] = 1
    with pytest.raises(ScenarioError) as err:
        parse_scenario(params)
    assert err.value.key == 'use_sim_time'


def test_explicit_planner_key_overrides_variant_default():
    params = _base_params()
    params['planner'] = {'variant': 'paper', 'max_accel_mrp_s2': 0.02, 'gamma_deg': 45.0}
    p = parse_scenario(params).planner
    assert (
        p.variant,
        p.direction_axis,
        p.max_accel_mrp_s2,
        p.gamma_deg,
        p.terminal_time_constant_s,
    ) == ('paper', 'paper', 0.02, 45.0, 0.0)


def test_fis_path_is_resolved_relative_to_scenario_file(tmp_path):
    (tmp_path / 'fis').mkdir()
    (tmp_path / 'fis' / 'mine.yaml').write_text('{}\n')
    params = _base_params()
    params['planner'] = {'fis_attractive': 'fis/mine.yaml'}
    path = tmp_path / 'scenario.yaml'
    path.write_text(_dump(params))
    sc = load_scenario(path)
    assert sc.planner.fis_attractive == str((tmp_path / 'fis' / 'mine.yaml').resolve())
    assert sc.planner.fis_repulsive == 'fis_repulsive.yaml'
    assert sc.source == str(path)


def test_mrp_longer_than_one_is_replaced_by_its_shadow_set(tmp_path):
    params = _base_params()
    params['initial_mrp'] = shadow(np.array([0.0, 0.0, 0.25])).tolist()  # [0, 0, -4]
    params['desired_mrp'] = [0.0, 1.2, 0.9]  # |sigma| = 1.5
    path = tmp_path / 's.yaml'
    path.write_text(_dump(params))
    sc = load_scenario(path)
    np.testing.assert_allclose(sc.initial_mrp, [0.0, 0.0, 0.25], atol=1e-15)
    np.testing.assert_allclose(sc.desired_mrp, shadow(np.array([0.0, 1.2, 0.9])), atol=1e-15)
    assert np.linalg.norm(sc.desired_mrp) <= 1.0


def test_error_string_format(tmp_path):
    params = _base_params()
    params['dt_s'] = 1
    path = tmp_path / 's.yaml'
    path.write_text(_dump(params))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert isinstance(err.value, ValueError)
    assert str(err.value) == f'{path}: dt_s: {err.value.reason}'
