"""Scenario loader (attitude_core.scenario) and the scenario files in scenarios/."""

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation, Slerp

from attitude_core.constraints import ConeGeometry, KeepInCones
from attitude_core.mrp import shadow
from attitude_core.scenario import (
    ArrivalConfig,
    PlannerConfig,
    ScenarioError,
    flatten_parameters,
    load_scenario,
    loads_scenario,
    parse_scenario,
    scenario_yaml,
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
    return float(sc.cone_geometry().min_margin_deg(path).min())


@pytest.mark.parametrize('path', SCENARIO_FILES, ids=lambda p: p.stem)
def test_scenario_file_loads_and_is_feasible(path):
    sc = load_scenario(path)
    assert sc.name == path.stem
    geometry = sc.cone_geometry()
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
    g = sc.cone_geometry(inflation_deg=2.0)
    assert g.samples == sc.planner.obstacle_samples == 180
    assert g.inflation_deg == 2.0
    assert sc.cone_geometry(samples=32).samples == 32


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


# --- keep-in cones ----------------------------------------------------------------------

_SUN = [0.2802, 0.7698, 0.5736]  # the keep_in.yaml Sun (RA 70 deg, Dec 35 deg)
_KI = 'keep_in.sun_sensor'


def _with_keep_in(params, **cone):
    """The base scenario with the sun sensor of scenarios/keep_in.yaml (start 13.0 deg,
    goal 11.1 deg inside its 70 deg cone); ``cone`` overrides its keys."""
    sensor = {'axis_body': [0.0, 0.7071, 0.7071], 'direction_inertial': _SUN, 'max_angle_deg': 70.0}
    sensor.update(cone)
    params['keep_in'] = {'names': ['sun_sensor'], 'sun_sensor': sensor}
    return params


def _keep_in(transform=lambda p: p, **cone):
    return lambda params: transform(_with_keep_in(params, **cone))


def _angle_deg(u, v):
    u, v = np.asarray(u, float), np.asarray(v, float)
    return float(
        np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))
    )


def test_keep_in_scenario_file_loads_with_its_cone():
    sc = load_scenario(SCENARIOS / 'keep_in.yaml')
    assert sc.keep_in_names == ('sun_sensor',)
    np.testing.assert_allclose(
        sc.keep_in_axes_body, [[0.0, np.sqrt(0.5), np.sqrt(0.5)]], atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.norm(sc.keep_in_directions_inertial, axis=1), 1.0)
    np.testing.assert_array_equal(sc.keep_in_max_angles_deg, [70.0])
    # The keep-in direction is the Sun, which is also a keep-out bright object.
    sun = sc.bright_object_names.index('sun')
    np.testing.assert_allclose(sc.keep_in_directions_inertial[0], sc.directions_inertial[sun])
    assert sc.constraint_names == (
        'star_tracker/object_1',
        'star_tracker/object_2',
        'star_tracker/object_3',
        'star_tracker/sun',
        'keep_in/sun_sensor',
    )
    g = sc.cone_geometry()
    assert (g.n_keep_out, g.n_keep_in, g.n_constraints) == (4, 1, len(sc.constraint_names))
    for a in (sc.keep_in_axes_body, sc.keep_in_directions_inertial, sc.keep_in_max_angles_deg):
        with pytest.raises(ValueError):
            a[0] = 1.0


def test_keep_in_cone_matters_in_the_keep_in_scenario():
    """Start and goal inside the sensor's cone by >= 5 deg, the direct eigenaxis rotation
    takes the Sun out of it, and a route round it exists (two eigenaxis legs)."""
    sc = load_scenario(SCENARIOS / 'keep_in.yaml')
    # Writable copies: SciPy refuses the scenario's read-only arrays.
    a, d, gamma = np.array(sc.keep_in_axes_body[0]), sc.keep_in_directions_inertial[0], 70.0
    for sigma in (sc.initial_mrp, sc.desired_mrp):
        inertial_axis = Rotation.from_mrp(np.array(sigma)).apply(a)
        assert gamma - _angle_deg(inertial_axis, d) >= 5.0
        np.testing.assert_allclose(
            sc.cone_geometry().keep_in_margins_deg(sigma), [gamma - _angle_deg(inertial_axis, d)]
        )
    # The direct rotation, sampled (SciPy slerp): the sensor axis leaves the cone.
    ends = Rotation.from_mrp(np.array([sc.initial_mrp, sc.desired_mrp]))
    path = Slerp([0.0, 1.0], ends)(np.linspace(0.0, 1.0, 2001))
    worst = gamma - max(_angle_deg(v, d) for v in path.apply(a))
    assert worst < -5.0
    keep_in_only = ConeGeometry(
        np.zeros((0, 3)),
        np.zeros(0),
        np.zeros((0, 3)),
        samples=16,
        keep_in=KeepInCones(sc.keep_in_axes_body, sc.keep_in_directions_inertial, [gamma]),
    )
    closed_form = keep_in_only.arc_min_margin_deg_single(sc.initial_mrp, sc.desired_mrp)
    assert closed_form == pytest.approx(worst, abs=0.01)
    # Through the waypoint named in the file, every constraint holds with >= 11 deg.
    geometry = sc.cone_geometry(samples=16)
    waypoint = np.array([-0.38, -0.73, -0.39])
    legs = (
        geometry.arc_min_margin_deg_single(sc.initial_mrp, waypoint),
        geometry.arc_min_margin_deg_single(waypoint, sc.desired_mrp),
    )
    assert min(legs) >= 11.0


def test_no_keep_in_means_empty_arrays_and_keep_out_names_only():
    sc = parse_scenario(_base_params())
    assert sc.keep_in_names == ()
    assert sc.keep_in_axes_body.shape == (0, 3)
    assert sc.keep_in_directions_inertial.shape == (0, 3)
    assert sc.keep_in_max_angles_deg.shape == (0,)
    assert sc.constraint_names == (
        'star_tracker/object_1',
        'star_tracker/object_2',
        'star_tracker/object_3',
    )
    g = sc.cone_geometry()
    assert g.n_keep_in == 0 and g.n_constraints == 3
    sigma = np.array([[0.1, -0.2, 0.3], [0.0, 0.0, 0.25]])
    np.testing.assert_array_equal(
        g.constraint_margins_deg(sigma), g.margins_deg(sigma).reshape(2, 3)
    )


def test_keep_in_geometry_and_names_follow_the_file_order():
    params = _base_params()
    params['keep_in'] = {
        'names': ['sun_sensor', 'antenna'],
        'sun_sensor': {
            'axis_body': [0.0, 0.7071, 0.7071],
            'direction_inertial': _SUN,
            'max_angle_deg': 70.0,
        },
        'antenna': {
            'axis_body': [0.0, 0.0, -1.0],
            'direction_inertial': [0.0, 0.0, -1.0],
            'max_angle_deg': 170.0,
        },
    }
    sc = parse_scenario(params)
    assert sc.keep_in_names == ('sun_sensor', 'antenna')
    assert sc.constraint_names[3:] == ('keep_in/sun_sensor', 'keep_in/antenna')
    sigma = np.random.default_rng(3).uniform(-0.5, 0.5, (20, 3))
    margins = sc.cone_geometry().constraint_margins_deg(sigma)
    for k, (axis, direction, gamma) in enumerate(
        (
            (params['keep_in']['sun_sensor']['axis_body'], _SUN, 70.0),
            ([0.0, 0.0, -1.0], [0.0, 0.0, -1.0], 170.0),
        )
    ):
        inertial = Rotation.from_mrp(sigma).apply(np.array(axis) / np.linalg.norm(axis))
        expected = [gamma - _angle_deg(v, direction) for v in inertial]
        np.testing.assert_allclose(margins[:, 3 + k], expected, atol=1e-9)


def test_an_empty_keep_in_list_means_none_as_the_nodes_see_it():
    """rcl leaves ``keep_in.names: []`` unset, so a node sees no keep-in cone; the loader
    agrees. The required lists still refuse an empty list."""
    params = _base_params()
    params['keep_in'] = {'names': []}
    sc = parse_scenario(params)
    assert sc.keep_in_names == () and sc.cone_geometry().n_keep_in == 0
    params['bright_objects']['names'] = []
    with pytest.raises(ScenarioError) as err:
        parse_scenario(params)
    assert err.value.key == 'bright_objects.names' and 'non-empty list' in err.value.reason


def test_keep_in_survives_the_scenario_yaml_round_trip():
    """Campaign draws and the recorder write dotted values with scenario_yaml and read
    them back with loads_scenario."""
    flat = flatten_parameters(_with_keep_in(_base_params()))
    sc = loads_scenario(scenario_yaml(flat))
    direct = parse_scenario(flat)
    assert sc.keep_in_names == direct.keep_in_names == ('sun_sensor',)
    for name in ('keep_in_axes_body', 'keep_in_directions_inertial', 'keep_in_max_angles_deg'):
        np.testing.assert_array_equal(getattr(sc, name), getattr(direct, name), err_msg=name)
    text = scenario_yaml(flat)
    assert 'keep_in:' in text and 'max_angle_deg: 70.0' in text
    # Without keep-in cones the text has no keep_in key (an empty list is not a ROS 2 value).
    assert 'keep_in' not in scenario_yaml(flatten_parameters(_base_params()))


def test_start_outside_a_keep_in_cone_is_refused_naming_the_key_the_cone_and_the_angle(tmp_path):
    params = _with_keep_in(_base_params())
    params['initial_mrp'] = [0.0, 0.0, 0.5]  # 106 deg about z: outside every keep-out cone
    path = tmp_path / 's.yaml'
    path.write_text(_dump(params))
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    off_axis = _angle_deg(
        Rotation.from_mrp([0.0, 0.0, 0.5]).apply([0.0, np.sqrt(0.5), np.sqrt(0.5)]), _SUN
    )
    assert off_axis > 70.0
    assert err.value.key == 'initial_mrp'
    assert 'outside the keep-in cone keep_in.sun_sensor' in err.value.reason
    assert f'{off_axis:.1f} deg from the direction' in err.value.reason
    assert f'margin {70.0 - off_axis:.1f} deg' in err.value.reason
    # The same attitude as the goal is refused on desired_mrp.
    params = _with_keep_in(_base_params())
    params['desired_mrp'] = [0.0, 0.0, 0.5]
    with pytest.raises(ScenarioError) as err:
        parse_scenario(params)
    assert err.value.key == 'desired_mrp' and 'keep_in.sun_sensor' in err.value.reason


def test_keep_in_margin_just_positive_is_accepted():
    """The refusal is at margin <= 0: a cone a little wider than the start's angle loads."""
    off_axis = _angle_deg(
        Rotation.from_mrp([0.0, 0.0, 0.5]).apply([0.0, np.sqrt(0.5), np.sqrt(0.5)]), _SUN
    )
    params = _with_keep_in(_base_params(), max_angle_deg=round(off_axis + 0.05, 3))
    params['initial_mrp'] = [0.0, 0.0, 0.5]
    sc = parse_scenario(params)
    assert 0.0 < float(sc.cone_geometry().keep_in_margins_deg(sc.initial_mrp)[0]) < 0.1


KEEP_IN_MALFORMED = [
    (
        'keep_in_axis_not_unit',
        _keep_in(axis_body=[0.0, 1.0, 1.0]),
        f'{_KI}.axis_body',
        'must be a unit vector (norm within 5% of 1), got norm 1.414',
    ),
    ('keep_in_axis_zero', _keep_in(axis_body=[0.0, 0.0, 0.0]), f'{_KI}.axis_body', 'non-zero'),
    (
        'keep_in_direction_not_unit',
        _keep_in(direction_inertial=[0.5, 0.0, 0.0]),
        f'{_KI}.direction_inertial',
        'got norm 0.5',
    ),
    (
        'keep_in_direction_short',
        _keep_in(direction_inertial=[0.0, 1.0]),
        f'{_KI}.direction_inertial',
        'expected a list of 3 floats, got 2 elements',
    ),
    (
        'keep_in_angle_0',
        _keep_in(max_angle_deg=0.0),
        f'{_KI}.max_angle_deg',
        'must be in (0, 180), got 0.0',
    ),
    (
        'keep_in_angle_180',
        _keep_in(max_angle_deg=180.0),
        f'{_KI}.max_angle_deg',
        'must be in (0, 180), got 180.0',
    ),
    (
        'keep_in_angle_negative',
        _keep_in(max_angle_deg=-10.0),
        f'{_KI}.max_angle_deg',
        'must be in (0, 180), got -10.0',
    ),
    (
        'keep_in_angle_int',
        _keep_in(max_angle_deg=70),
        f'{_KI}.max_angle_deg',
        'expected float, got integer 70; write it as a YAML float, e.g. 70.0',
    ),
    (
        'keep_in_without_axis',
        _keep_in(_delete(f'{_KI}.axis_body')),
        f'{_KI}.axis_body',
        'missing required key',
    ),
    (
        'keep_in_without_angle',
        _keep_in(_delete(f'{_KI}.max_angle_deg')),
        f'{_KI}.max_angle_deg',
        'missing required key',
    ),
    (
        'keep_in_listed_without_keys',
        _set('keep_in.names', ['sun_sensor']),
        f'{_KI}.axis_body',
        'missing required key',
    ),
    (
        'keep_in_unknown_key',
        _keep_in(_set(f'{_KI}.max_angle', 60.0)),
        f'{_KI}.max_angle',
        f"unknown key; did you mean '{_KI}.max_angle_deg'?",
    ),
    (
        'keep_in_typo_in_axis',
        _keep_in(_set(f'{_KI}.axis_bdy', [0.0, 0.0, 1.0])),
        f'{_KI}.axis_bdy',
        f"did you mean '{_KI}.axis_body'?",
    ),
    (
        'keep_in_not_listed',
        _keep_in(_set('keep_in.antenna.max_angle_deg', 60.0)),
        'keep_in.antenna.max_angle_deg',
        "unknown key; 'antenna' is not listed in keep_in.names",
    ),
    (
        'keep_in_keys_without_names',
        _set(f'{_KI}.max_angle_deg', 60.0),
        f'{_KI}.max_angle_deg',
        "'sun_sensor' is not listed in keep_in.names",
    ),
    (
        'keep_in_empty_names_with_a_cone',
        _keep_in(_set('keep_in.names', [])),
        f'{_KI}.axis_body',
        "unknown key; 'sun_sensor' is not listed in keep_in.names",
    ),
    (
        'keep_in_duplicate_names',
        _keep_in(_set('keep_in.names', ['sun_sensor', 'sun_sensor'])),
        'keep_in.names',
        "duplicate names ['sun_sensor']",
    ),
    (
        'keep_in_bad_name',
        _set('keep_in.names', ['sun-sensor']),
        'keep_in.names',
        "invalid name 'sun-sensor'",
    ),
    (
        'keep_in_names_not_a_list',
        _set('keep_in.names', 'sun_sensor'),
        'keep_in.names',
        'expected a non-empty list of names',
    ),
]


@pytest.mark.parametrize(
    'transform,key,reason',
    [c[1:] for c in KEEP_IN_MALFORMED],
    ids=[c[0] for c in KEEP_IN_MALFORMED],
)
def test_malformed_keep_in_is_refused_naming_the_key(tmp_path, transform, key, reason):
    test_malformed_scenario_is_refused(tmp_path, transform, key, reason)
