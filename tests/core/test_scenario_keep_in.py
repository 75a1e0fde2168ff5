"""Keep-in cones of the scenario loader (attitude_core.config.scenario) and of
``scenarios/keep_in.yaml``."""

from pathlib import Path

import numpy as np
import pytest
from scenario_params import _SUN, _base_params, _dump, _with_keep_in
from scipy.spatial.transform import Rotation, Slerp

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import (
    load_scenario,
    loads_scenario,
    parse_scenario,
    scenario_yaml,
)
from attitude_core.models.constraints import ConeGeometry, KeepInCones

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / 'scenarios'


# --- keep-in cones ----------------------------------------------------------------------


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
