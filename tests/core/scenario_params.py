"""The scenario parameters the scenario tests edit (``test_scenario.py``,
``test_scenario_malformed.py``, ``test_scenario_keep_in.py``): a minimal valid scenario
as a nested ``ros__parameters`` mapping, its YAML text, and the sun sensor keep-in cone of
``scenarios/keep_in.yaml``."""

import yaml


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


def _dump(params):
    return yaml.safe_dump({'/**': {'ros__parameters': params}}, sort_keys=False)


_SUN = [0.2802, 0.7698, 0.5736]  # the keep_in.yaml Sun (RA 70 deg, Dec 35 deg)


def _with_keep_in(params, **cone):
    """The base scenario with the sun sensor of scenarios/keep_in.yaml (start 13.0 deg,
    goal 11.1 deg inside its 70 deg cone); ``cone`` overrides its keys."""
    sensor = {'axis_body': [0.0, 0.7071, 0.7071], 'direction_inertial': _SUN, 'max_angle_deg': 70.0}
    sensor.update(cone)
    params['keep_in'] = {'names': ['sun_sensor'], 'sun_sensor': sensor}
    return params
