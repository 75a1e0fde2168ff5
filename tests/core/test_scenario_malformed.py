"""Malformed scenario files: the loader (attitude_core.config.scenario) refuses each one
naming the key and the reason."""

import copy
from pathlib import Path

import pytest
import yaml
from scenario_params import _base_params, _dump, _with_keep_in

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario

ROOT = Path(__file__).resolve().parents[2]


# --- malformed inputs -----------------------------------------------------------------


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


# --- keep-in cones, malformed -------------------------------------------------------

_KI = 'keep_in.sun_sensor'


def _keep_in(transform=lambda p: p, **cone):
    return lambda params: transform(_with_keep_in(params, **cone))


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
