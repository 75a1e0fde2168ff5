"""Scenario loader (attitude_core.scenario) and the scenario files in scenarios/."""

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from attitude_core.mrp import shadow
from attitude_core.scenario import (
    ArrivalConfig,
    PlannerConfig,
    ScenarioError,
    flatten_parameters,
    load_scenario,
    parse_scenario,
)

ROOT = Path(__file__).resolve().parents[1]
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
    return float(sc.keep_out().min_margin_deg(path).min())


@pytest.mark.parametrize('path', SCENARIO_FILES, ids=lambda p: p.stem)
def test_scenario_file_loads_and_is_feasible(path):
    sc = load_scenario(path)
    assert sc.name == path.stem
    geometry = sc.keep_out()
    need = 0.0 if path.stem in PAPER_CASES else 5.0
    for sigma in (sc.initial_mrp, sc.desired_mrp):
        margin = float(geometry.min_margin_deg(sigma))
        assert margin > 0.0 and margin >= need
    if path.stem not in PAPER_CASES:
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
    g = sc.keep_out(inflation_deg=2.0)
    assert g.samples == sc.planner.obstacle_samples == 180
    assert g.inflation_deg == 2.0
    assert sc.keep_out(samples=32).samples == 32


def _base_params():
    """A minimal valid scenario (Table 1, case 1) as a nested ros__parameters mapping."""
    return {
        'scenario_name': 'base',
        'sim_time_s': 150.0,
        'dt_s': 0.1,
        'inertia_kgm2': [10.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0],
        'initial_mrp': [0.0, 0.0, 0.25],
        'desired_mrp': [0.0, -0.2, -0.7],
        'initial_rate_rad_s': [0.0, 0.0, 0.0],
        'instruments': {
            'names': ['star_tracker'],
            'star_tracker': {'boresight_body': [1.0, 0.0, 0.0], 'half_angle_deg': 20.0},
        },
        'bright_objects': {
            'names': ['object_1', 'object_2', 'object_3'],
            'object_1': {'direction_inertial': [0.0, -0.981, -0.196]},
            'object_2': {'direction_inertial': [-1.0, 0.0, 0.0]},
            'object_3': {'direction_inertial': [0.958, 0.0, 0.287]},
        },
    }


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


# --- malformed inputs -----------------------------------------------------------------


def _dump(params):
    return yaml.safe_dump({'/**': {'ros__parameters': params}}, sort_keys=False)


def _set(dotted, value):
    def mutate(params):
        node = params
        *parents, leaf = dotted.split('.')
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
        return params

    return mutate


def _delete(dotted):
    def mutate(params):
        node = params
        *parents, leaf = dotted.split('.')
        for p in parents:
            node = node[p]
        del node[leaf]
        return params

    return mutate


def _raw(text):
    return lambda params: text


def _append(line):
    """Append a dotted key at ros__parameters level (raw YAML, e.g. an unquoted 1e-3)."""
    return lambda params: _dump(params) + f'    {line}\n'


def _diag(a, b, c):
    return [a, 0.0, 0.0, 0.0, b, 0.0, 0.0, 0.0, c]


_ST = 'instruments.star_tracker'
MALFORMED = [
    # id, transform of the base params (dict -> dumped, or raw text), key, reason substring
    ('missing_key', _delete('sim_time_s'), 'sim_time_s', 'missing required key'),
    ('missing_inertia', _delete('inertia_kgm2'), 'inertia_kgm2', 'missing required key'),
    (
        'int_where_float',
        _set('dt_s', 1),
        'dt_s',
        'expected float, got integer 1; write it as a YAML float, e.g. 1.0',
    ),
    (
        'int_in_float_array',
        _set('inertia_kgm2', [10, 0, 0, 0, 10, 0, 0, 0, 10]),
        'inertia_kgm2',
        'element 0: expected float, got integer 10',
    ),
    (
        'mixed_array',
        _set('initial_mrp', [0.0, 0, 0.25]),
        'initial_mrp',
        'element 1: expected float, got integer 0',
    ),
    (
        'string_where_float',
        _set('sim_time_s', 'long'),
        'sim_time_s',
        "expected float, got string 'long'",
    ),
    (
        'exponent_without_dot',
        _append('arrival.rate_tol_rad_s: 1e-3'),
        'arrival.rate_tol_rad_s',
        'e.g. 0.001',
    ),
    (
        'bool_where_float',
        _set('controller.kp_over_j', True),
        'controller.kp_over_j',
        'expected float, got boolean',
    ),
    (
        'nan',
        _set('initial_mrp', [float('nan'), 0.0, 0.25]),
        'initial_mrp',
        'element 0: must be finite',
    ),
    ('inf', _set('sim_time_s', float('inf')), 'sim_time_s', 'must be finite'),
    (
        'wrong_length',
        _set('desired_mrp', [0.0, -0.2]),
        'desired_mrp',
        'expected a list of 3 floats, got 2',
    ),
    (
        'scalar_where_vector',
        _set('initial_rate_rad_s', 0.0),
        'initial_rate_rad_s',
        'expected a list of 3 floats',
    ),
    (
        'zero_boresight',
        _set(f'{_ST}.boresight_body', [0.0, 0.0, 0.0]),
        f'{_ST}.boresight_body',
        'non-zero',
    ),
    (
        'boresight_norm_2',
        _set(f'{_ST}.boresight_body', [2.0, 0.0, 0.0]),
        f'{_ST}.boresight_body',
        'norm 2',
    ),
    (
        'direction_norm',
        _set('bright_objects.object_2.direction_inertial', [-1.1, 0.0, 0.0]),
        'bright_objects.object_2.direction_inertial',
        'unit vector',
    ),
    ('beta_0', _set(f'{_ST}.half_angle_deg', 0.0), f'{_ST}.half_angle_deg', 'must be in (0, 90)'),
    ('beta_90', _set(f'{_ST}.half_angle_deg', 90.0), f'{_ST}.half_angle_deg', 'must be in (0, 90)'),
    ('beta_negative', _set(f'{_ST}.half_angle_deg', -5.0), f'{_ST}.half_angle_deg', 'got -5.0'),
    (
        'non_symmetric_inertia',
        _set('inertia_kgm2', [10.0, 1.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0]),
        'inertia_kgm2',
        'symmetric',
    ),
    (
        'non_pd_inertia',
        _set('inertia_kgm2', _diag(10.0, 10.0, -1.0)),
        'inertia_kgm2',
        'positive definite',
    ),
    (
        'triangle_inequality',
        _set('inertia_kgm2', _diag(1.0, 1.0, 10.0)),
        'inertia_kgm2',
        'triangle inequality',
    ),
    ('dt_zero', _set('dt_s', 0.0), 'dt_s', 'must be > 0'),
    ('dt_negative', _set('dt_s', -0.1), 'dt_s', 'must be > 0'),
    ('sim_time_below_dt', _set('sim_time_s', 0.05), 'sim_time_s', 'must be >= dt_s'),
    (
        'start_inside_cone',
        _set('initial_mrp', [0.0, 0.0, 0.0]),
        'initial_mrp',
        "inside the keep-out cone of instrument 'star_tracker' and bright object 'object_3' (margin -3.3 deg)",
    ),
    (
        'goal_inside_cone',
        _set('desired_mrp', [0.0, 0.0, 0.0]),
        'desired_mrp',
        "inside the keep-out cone of instrument 'star_tracker' and bright object 'object_3'",
    ),
    (
        'yaml_syntax_error',
        _raw('/**:\n  ros__parameters:\n    sim_time_s: [150.0, 1.0\n'),
        None,
        'YAML syntax error',
    ),
    (
        'yaml_duplicate_key',
        _raw('/**:\n  ros__parameters:\n    dt_s: 0.1\n    dt_s: 0.2\n'),
        None,
        "invalid YAML: duplicate key 'dt_s'",
    ),
    (
        'unknown_key_with_suggestion',
        _set('sim_time', 150.0),
        'sim_time',
        "unknown key; did you mean 'sim_time_s'?",
    ),
    (
        'unknown_planner_key',
        _set('planner.gama_deg', 60.0),
        'planner.gama_deg',
        "did you mean 'planner.gamma_deg'?",
    ),
    (
        'unknown_instrument_key',
        _set(f'{_ST}.half_angle', 20.0),
        f'{_ST}.half_angle',
        f"did you mean '{_ST}.half_angle_deg'?",
    ),
    (
        'instrument_not_listed',
        _set('instruments.camera.half_angle_deg', 15.0),
        'instruments.camera.half_angle_deg',
        "unknown key; 'camera' is not listed in instruments.names",
    ),
    ('empty_file', _raw(''), None, 'file is empty'),
    ('comment_only_file', _raw('# nothing here\n'), None, 'file is empty'),
    (
        'wrong_top_level',
        lambda p: yaml.safe_dump({'ros__parameters': p}),
        None,
        'top level must be exactly',
    ),
    (
        'node_name_top_level',
        lambda p: yaml.safe_dump({'planner_node': {'ros__parameters': p}}),
        None,
        'top level must be exactly',
    ),
    (
        'instrument_without_boresight',
        lambda p: _set('instruments.camera.half_angle_deg', 15.0)(
            _set('instruments.names', ['star_tracker', 'camera'])(p)
        ),
        'instruments.camera.boresight_body',
        'missing required key',
    ),
    (
        'duplicate_instrument_names',
        _set('instruments.names', ['star_tracker', 'star_tracker']),
        'instruments.names',
        "duplicate names ['star_tracker']",
    ),
    ('empty_instrument_list', _set('instruments.names', []), 'instruments.names', 'non-empty list'),
    (
        'bad_instrument_name',
        _set('instruments.names', ['star-tracker']),
        'instruments.names',
        "invalid name 'star-tracker'",
    ),
    ('bad_scenario_name', _set('scenario_name', '1st_case'), 'scenario_name', 'invalid name'),
    (
        'unknown_variant',
        _set('planner.variant', 'fast'),
        'planner.variant',
        "must be one of ['improved', 'paper']",
    ),
    (
        'bad_direction_axis',
        _set('planner.direction_axis', 'x'),
        'planner.direction_axis',
        "must be one of ['goal_plane', 'paper']",
    ),
    (
        'negative_safety_margin',
        _set('planner.safety_margin_deg', -1.0),
        'planner.safety_margin_deg',
        'must be in [0, 45)',
    ),
    ('gamma_180', _set('planner.gamma_deg', 180.0), 'planner.gamma_deg', 'must be in [0, 180)'),
    (
        'obstacle_samples_float',
        _set('planner.obstacle_samples', 180.0),
        'planner.obstacle_samples',
        'expected integer, got float',
    ),
    (
        'obstacle_samples_small',
        _set('planner.obstacle_samples', 8),
        'planner.obstacle_samples',
        'must be in [16, 100000]',
    ),
    ('negative_gain', _set('controller.kd_over_j', -3.1), 'controller.kd_over_j', 'must be > 0'),
    (
        'fis_path_missing',
        _set('planner.fis_repulsive', 'data/none.yaml'),
        'planner.fis_repulsive',
        'does not exist',
    ),
    ('fis_empty', _set('planner.fis_attractive', ''), 'planner.fis_attractive', 'non-empty string'),
    (
        'arrival_tol_zero',
        _set('arrival.attitude_tol_deg', 0.0),
        'arrival.attitude_tol_deg',
        'must be > 0',
    ),
]


@pytest.mark.parametrize(
    'transform,key,reason', [c[1:] for c in MALFORMED], ids=[c[0] for c in MALFORMED]
)
def test_malformed_scenario_is_refused(tmp_path, transform, key, reason):
    out = transform(copy.deepcopy(_base_params()))
    path = tmp_path / 'scenario.yaml'
    path.write_text(out if isinstance(out, str) else _dump(out))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert err.value.key == key, str(err.value)
    assert reason in err.value.reason, str(err.value)
    assert str(err.value).startswith(f'{path}: ' + (f'{key}: ' if key else ''))


def test_yaml_syntax_error_names_the_line(tmp_path):
    path = tmp_path / 's.yaml'
    path.write_text('/**:\n  ros__parameters:\n    dt_s: 0.1\n   bad: [\n')
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert err.value.key is None and 'line 4, column' in err.value.reason
    assert 'bad: [' in err.value.reason  # the offending YAML line is quoted


def test_missing_file():
    with pytest.raises(ScenarioError) as err:
        load_scenario(ROOT / 'scenarios' / 'does_not_exist.yaml')
    assert err.value.key is None and 'cannot read file' in err.value.reason


def test_base_params_are_valid(tmp_path):
    path = tmp_path / 's.yaml'
    path.write_text(_dump(_base_params()))
    assert load_scenario(path).name == 'base'
