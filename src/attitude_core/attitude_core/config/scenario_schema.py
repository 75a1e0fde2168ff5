"""The scenario's parameter table: every scenario key as one :class:`Param` row.

The loader (:mod:`attitude_core.config.scenario`) validates with these rows and the nodes
declare them (``attitude_ros.params``); each node declares only the rows it reads
(:mod:`attitude_core.config.node_parameters`). Per listed name, the rows of
:data:`INSTRUMENT_PARAMETERS` live under ``instruments.<name>.``, those of
:data:`OBJECT_PARAMETERS` under ``bright_objects.<name>.`` and those of
:data:`KEEP_IN_PARAMETERS` under ``keep_in.<name>.``. ``instruments.names`` and
``bright_objects.names`` are required; ``keep_in.names`` is optional (absent, or an
empty list, which rcl leaves unset: no keep-in cone). A :class:`ByVariant` default
depends on ``planner.variant``, which therefore comes before them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude_core.config.parameters import REQUIRED, Bounds, ByVariant, Param, ParamKind, ge, gt
from attitude_core.fsw.guidance.fuzzy.files import fis_value
from attitude_core.fsw.guidance.planner_config import (
    DirectionAxis,
    PlannerVariant,
    PlanningFrame,
)
from attitude_core.models.ephemeris import BODIES, parse_epoch_utc

__all__ = [
    "SCENARIO_PARAMETERS",
    "GROUP_PARAMETERS",
    "INSTRUMENT_PARAMETERS",
    "OBJECT_PARAMETERS",
    "KEEP_IN_PARAMETERS",
    "ORBIT_PARAMETERS",
    "SENSOR_PARAMETERS",
    "SENSOR_REQUIRED",
    "FDIR_PARAMETERS",
    "LINK_PARAMETERS",
    "DISTURBANCE_PARAMETERS",
    "WHEEL_PARAMETERS",
    "EXCLUSION_PARAMETER",
    "GROUPS",
    "OPTIONAL_GROUPS",
    "MAX_STEPS",
    "group_names_param",
]

MAX_STEPS = 10_000_000  # about 1 GB of trajectory arrays


def _rigid_body(j: Any) -> str | None:
    scale = float(np.abs(j).max())
    if float(np.abs(j - j.T).max()) > 1e-9 * scale:
        return f"must be symmetric, got {j.tolist()}"
    moments = np.linalg.eigvalsh(0.5 * (j + j.T))
    if moments[0] <= 0.0:
        return f"must be positive definite, principal moments {moments.tolist()}"
    if moments[2] > moments[0] + moments[1] + 1e-9 * moments[2]:
        return (
            f"principal moments {moments.tolist()} violate the triangle inequality "
            "(J3 <= J1 + J2); not a physical rigid body"
        )
    return None


def _epoch(text: Any) -> str | None:
    try:
        parse_epoch_utc(str(text))
    except ValueError as exc:
        return str(exc)
    return None


def _positive_vector(v: Any) -> str | None:
    if not all(float(x) > 0.0 for x in v):
        return f"every element must be > 0, got {[float(x) for x in v]}"
    return None


def _outage_pairs(v: Any) -> str | None:
    if len(v) % 2:
        return f"must be start and duration pairs (an even count), got {len(v)} numbers"
    for start, duration in zip(v[0::2], v[1::2], strict=True):
        if start < 0.0 or duration <= 0.0:
            return f"each pair is a start >= 0 and a duration > 0 (s), got [{start}, {duration}]"
    return None


ORBIT_PARAMETERS = (
    Param(
        "orbit.semi_major_axis_km",
        ParamKind.FLOAT,
        "two-body orbit at the epoch, GCRS: semi-major axis, km (absent: no orbit)",
        None,
        gt(0.0),
    ),
    Param(
        "orbit.eccentricity",
        ParamKind.FLOAT,
        "orbit eccentricity (elliptic)",
        None,
        Bounds(0.0, 1.0, hi_open=True),
    ),
    Param(
        "orbit.inclination_deg",
        ParamKind.FLOAT,
        "orbit inclination to the GCRS equator, deg",
        None,
        Bounds(0.0, 180.0),
    ),
    Param("orbit.raan_deg", ParamKind.FLOAT, "right ascension of the ascending node, deg", None),
    Param("orbit.arg_perigee_deg", ParamKind.FLOAT, "argument of perigee, deg", None),
    Param("orbit.true_anomaly_deg", ParamKind.FLOAT, "true anomaly at the epoch, deg", None),
)
"""The ``orbit.*`` keys: all six or none."""

SENSOR_PARAMETERS = (
    Param(
        "sensors.seed",
        ParamKind.INT,
        "seed of the sensor noise: a run is reproducible (absent with every sensors.* "
        "key: perfect knowledge, the simulator's state fed to the loop)",
        None,
        ge(0),
    ),
    Param(
        "sensors.star_tracker.noise_arcsec",
        ParamKind.VEC3,
        "star tracker error, 1-sigma about body x, y, z (a rotation in body axes), arcsec",
        None,
        check=_positive_vector,
    ),
    Param(
        "sensors.star_tracker.rate_hz",
        ParamKind.FLOAT,
        "star tracker sample rate, Hz (a sample at t = 0, then one per period)",
        None,
        gt(0.0),
    ),
    Param(
        "sensors.star_tracker.max_rate_deg_s",
        ParamKind.FLOAT,
        "no star tracker solution while the body turns faster than this, deg/s (absent: "
        "any rate); the guidance keeps the body's rate under 0.8 of it",
        None,
        gt(0.0),
    ),
    Param(
        "sensors.star_tracker.outages",
        ParamKind.FLOATS,
        "star tracker outages: a flat list of start and duration pairs, s (the keep-out "
        "buffer covers the attitude 3-sigma at the end of the longest)",
        None,
        check=_outage_pairs,
    ),
    Param(
        "sensors.star_tracker.instrument",
        ParamKind.NAME,
        "the instrument that is the star tracker: no solution while a bright object is "
        "inside its exclusion (absent: never blinded)",
        None,
    ),
    Param(
        "sensors.gyro.noise_rad_s",
        ParamKind.FLOAT,
        "gyro white noise, 1-sigma per sample (one per dt_s) and axis, rad/s",
        None,
        ge(0.0),
    ),
    Param(
        "sensors.gyro.bias_rad_s",
        ParamKind.VEC3,
        "gyro bias at t = 0, body axes, rad/s (default zero; the estimator does not know it)",
        None,
    ),
    Param(
        "sensors.gyro.bias_walk_rad_s2",
        ParamKind.FLOAT,
        "gyro bias random walk sigma_u, rad/s per sqrt(s) (rad s^-3/2): the bias moves by "
        "sigma_u sqrt(dt) per sample (default 0)",
        None,
        ge(0.0),
    ),
    Param(
        "sensors.gyro.bias_prior_rad_s",
        ParamKind.FLOAT,
        "the estimator's 1-sigma on the initial bias, per axis, rad/s (default 1e-3)",
        None,
        gt(0.0),
    ),
)
"""The ``sensors.*`` keys: absent, perfect knowledge; else ``seed``, the star tracker's
noise and rate and the gyro's noise are required (:func:`attitude_core.config.scenario`)."""

SENSOR_REQUIRED = (
    "sensors.seed",
    "sensors.star_tracker.noise_arcsec",
    "sensors.star_tracker.rate_hz",
    "sensors.gyro.noise_rad_s",
)


FDIR_PARAMETERS = (
    Param(
        "fdir.state_timeout_s",
        ParamKind.FLOAT,
        "a measured state older than this (stack clock) is stale: the loop flies on the "
        "predicted state, s (absent: 3 steps)",
        None,
        gt(0.0),
    ),
    Param(
        "fdir.predict_s",
        ParamKind.FLOAT,
        "without a state for this long, brake the predicted rate to zero, then command "
        "zero torque, s",
        3.0,
        gt(0.0),
    ),
    Param(
        "fdir.safe_after_s",
        ParamKind.FLOAT,
        "without a state for this long: safe mode (zero torque; the run ends), s",
        10.0,
        gt(0.0),
    ),
)
"""The state watchdog's limits (:class:`attitude_core.fsw.fdir.fdir_config.FdirConfig`)."""

LINK_PARAMETERS = (
    Param(
        "link.state_latency_s",
        ParamKind.FLOAT,
        "rehearsal link: every state the simulator publishes arrives this late, s "
        "(absent with every link.* key: no link, states published as they are made)",
        None,
        ge(0.0),
    ),
    Param(
        "link.jitter_s",
        ParamKind.FLOAT,
        "rehearsal link: plus a uniform delay in [-jitter_s, +jitter_s], s",
        None,
        ge(0.0),
    ),
    Param(
        "link.drop_rate",
        ParamKind.FLOAT,
        "rehearsal link: share of states lost",
        None,
        Bounds(0.0, 1.0, hi_open=True),
    ),
    Param(
        "link.outages",
        ParamKind.FLOATS,
        "rehearsal link: states withheld over these windows, a flat list of start and "
        "duration pairs, simulated s",
        None,
        check=_outage_pairs,
    ),
    Param("link.seed", ParamKind.INT, "rehearsal link: seed of the draws", None, ge(0)),
)
"""The ``link.*`` keys (:class:`attitude_core.models.link_spec.LinkSpec`): any one
declares the link, the others default to none."""

DISTURBANCE_PARAMETERS = (
    Param(
        "disturbances.gravity_gradient",
        ParamKind.BOOL,
        "gravity-gradient torque on the spacecraft from its orbit (needs orbit.*)",
        False,
    ),
    Param(
        "disturbances.constant_torque_nm",
        ParamKind.VEC3,
        "a constant external torque, body axes, N m (absent: none)",
        None,
    ),
)
"""External torques on the plant (:mod:`attitude_core.world.disturbances`)."""

SCENARIO_PARAMETERS = (
    Param("scenario_name", ParamKind.NAME, "name used in outputs ([A-Za-z][A-Za-z0-9_]*)"),
    Param("sim_time_s", ParamKind.FLOAT, "simulated time, s (>= dt_s)", bounds=gt(0.0)),
    Param("dt_s", ParamKind.FLOAT, "guidance, control and integration step, s", bounds=gt(0.0)),
    Param(
        "inertia_kgm2",
        ParamKind.MATRIX3,
        "inertia J about the body axes, kg m^2, row-major 3x3, SPD (eq. 4)",
        check=_rigid_body,
    ),
    Param(
        "initial_mrp",
        ParamKind.MRP,
        "initial attitude sigma_BN(0), MRP (|sigma| > 1 taken as its shadow set)",
    ),
    Param(
        "desired_mrp",
        ParamKind.MRP,
        "desired attitude sigma_d = sigma_DN, MRP (required without plan.*; absent with one)",
        None,
    ),
    Param("initial_rate_rad_s", ParamKind.VEC3, "initial body rate omega_BN(0), body axes, rad/s"),
    Param(
        "epoch_utc",
        ParamKind.STR,
        "UTC date-time of t = 0, ISO 8601 (needed by ephemeris objects; absent: none)",
        None,
        check=_epoch,
    ),
    *ORBIT_PARAMETERS,
    Param(
        "controller.kp_over_j",
        ParamKind.FLOAT,
        "proportional gain Kp = kp_over_j J, 1/s^2 (paper 5.5)",
        5.5,
        gt(0.0),
    ),
    Param(
        "controller.kd_over_j",
        ParamKind.FLOAT,
        "derivative gain Kd = kd_over_j J, 1/s (paper 3.1)",
        3.1,
        gt(0.0),
    ),
    Param(
        "planner.variant",
        ParamKind.STR,
        "FEPF variant whose defaults apply",
        "improved",
        choices=PlannerVariant,
    ),
    Param(
        "planner.direction_axis",
        ParamKind.STR,
        "repulsive rotation axis (eq. 9)",
        ByVariant("goal_plane", "paper"),
        choices=DirectionAxis,
    ),
    Param(
        "planner.gamma_deg",
        ParamKind.FLOAT,
        "repulsive rotation angle gamma, deg",
        ByVariant(60.0, 10.0),
        Bounds(0.0, 180.0, hi_open=True),
    ),
    Param(
        "planner.fis_attractive",
        ParamKind.DATA_FILE,
        "attractive FIS data (packaged name or path)",
        ByVariant("fis_attractive.yaml", "fis_attractive_paper.yaml"),
        resolve=fis_value,
    ),
    Param(
        "planner.fis_repulsive",
        ParamKind.DATA_FILE,
        "repulsive FIS data (packaged name or path)",
        ByVariant("fis_repulsive.yaml", "fis_repulsive_paper.yaml"),
        resolve=fis_value,
    ),
    Param(
        "planner.max_attractive_rate_mrp_s",
        ParamKind.FLOAT,
        "attractive speed scale, MRP/s",
        ByVariant(0.03, 0.03),
        gt(0.0),
    ),
    Param(
        "planner.max_repulsive_rate_mrp_s",
        ParamKind.FLOAT,
        "repulsive speed scale, MRP/s",
        ByVariant(0.03, 0.03),
        ge(0.0),
    ),
    Param(
        "planner.influence_distance_mrp",
        ParamKind.FLOAT,
        "obstacle influence distance, MRP",
        ByVariant(0.3, 0.3),
        gt(0.0),
    ),
    Param(
        "planner.safety_margin_deg",
        ParamKind.FLOAT,
        "buffer added to every cone for planning, deg",
        ByVariant(2.0, 2.0),
        Bounds(0.0, 45.0, hi_open=True),
    ),
    Param(
        "planner.max_accel_mrp_s2",
        ParamKind.FLOAT,
        "target acceleration bound, MRP/s^2 (0: none)",
        ByVariant(0.01, 0.0),
        ge(0.0),
    ),
    Param(
        "planner.terminal_time_constant_s",
        ParamKind.FLOAT,
        "terminal rate time constant, s (0: none)",
        ByVariant(2.0, 0.0),
        ge(0.0),
    ),
    Param(
        "planner.goal_tolerance_mrp",
        ParamKind.FLOAT,
        "goal capture distance, MRP",
        ByVariant(1.0e-4, 1.0e-4),
        gt(0.0),
    ),
    Param(
        "planner.stuck_timeout_s",
        ParamKind.FLOAT,
        "no-progress time before status stuck, s",
        ByVariant(10.0, 10.0),
        gt(0.0),
    ),
    Param(
        "planner.obstacle_samples",
        ParamKind.INT,
        "rim samples per keep-out cone",
        ByVariant(180, 180),
        Bounds(16, 100_000),
    ),
    Param(
        "planner.planning_frame",
        ParamKind.STR,
        "MRPs the FEPF is formed in: 'target' (relative to the current target: the short "
        "way) or 'inertial' (sigma_BN, the paper's)",
        ByVariant("target", "inertial"),
        choices=PlanningFrame,
    ),
    Param(
        "planner.global_route",
        ParamKind.BOOL,
        "follow a global route's waypoints (false: the FEPF alone; feasibility is "
        "checked either way)",
        ByVariant(True, False),
    ),
    Param(
        "planner.roadmap_nodes",
        ParamKind.INT,
        "attitudes of the global route's roadmap (its resolution)",
        ByVariant(4096, 4096),
        Bounds(256, 262_144),
    ),
    Param(
        "actuators.max_torque_nm",
        ParamKind.VEC3,
        "per-body-axis torque bound of the actuators, N m (each > 0; absent: unlimited)",
        None,
        check=_positive_vector,
    ),
    Param(
        "actuators.max_rate_rad_s",
        ParamKind.FLOAT,
        "body-rate bound the guidance must respect, rad/s (absent: unlimited)",
        None,
        gt(0.0),
    ),
    Param(
        "arrival.attitude_tol_deg",
        ParamKind.FLOAT,
        "arrival: attitude error bound, deg",
        0.5,
        gt(0.0),
    ),
    Param(
        "arrival.rate_tol_rad_s",
        ParamKind.FLOAT,
        "arrival: body rate bound, rad/s",
        1.0e-3,
        gt(0.0),
    ),
    *SENSOR_PARAMETERS,
    *FDIR_PARAMETERS,
    *LINK_PARAMETERS,
    *DISTURBANCE_PARAMETERS,
)
"""Top-level, controller, planner, arrival and sensor keys, in validation order."""

INSTRUMENT_PARAMETERS = (
    Param("boresight_body", ParamKind.UNIT3, "instrument boresight s_i, body axes, unit vector"),
    Param(
        "half_angle_deg",
        ParamKind.FLOAT,
        "keep-out half-angle beta_i, deg: the exclusion of every avoided object without "
        "its own exclusion_deg (required unless each has one)",
        None,
        bounds=Bounds(0.0, 90.0, lo_open=True, hi_open=True),
    ),
    Param(
        "avoids",
        ParamKind.NAMES,
        "the bright objects this instrument must avoid (absent: all)",
        None,
    ),
)
EXCLUSION_PARAMETER = Param(
    "exclusion_deg",
    ParamKind.FLOAT,
    "exclusion half-angle of this instrument from this object's limb, deg",
    None,
    bounds=Bounds(0.0, 180.0, hi_open=True),
)
"""``instruments.<name>.exclusion_deg.<object>``: one row per instrument and object."""
OBJECT_PARAMETERS = (
    Param(
        "direction_inertial",
        ParamKind.UNIT3,
        "bright-object direction c_j at t = 0, inertial axes, unit vector (or ephemeris)",
        None,
    ),
    Param(
        "ephemeris",
        ParamKind.STR,
        "the body this object is, seen from the spacecraft (instead of direction_inertial)",
        None,
        choices=BODIES,
    ),
    Param(
        "rate_inertial_rad_s",
        ParamKind.VEC3,
        "constant inertial rotation rate of direction_inertial from t = 0, rad/s (absent: fixed)",
        None,
    ),
)
KEEP_IN_PARAMETERS = (
    Param("axis_body", ParamKind.UNIT3, "keep-in body axis a_k, body axes, unit vector"),
    Param(
        "direction_inertial",
        ParamKind.UNIT3,
        "direction d_k the axis must stay near, inertial axes, unit vector (or ephemeris)",
        None,
    ),
    Param(
        "ephemeris",
        ParamKind.STR,
        "the body whose centre the axis must stay near (instead of direction_inertial)",
        None,
        choices=BODIES,
    ),
    Param(
        "max_angle_deg",
        ParamKind.FLOAT,
        "largest angle gamma_k between the axis and the direction, deg",
        bounds=Bounds(0.0, 180.0, lo_open=True, hi_open=True),
    ),
)
WHEEL_PARAMETERS = (
    Param(
        "spin_axis_body",
        ParamKind.UNIT3,
        "reaction wheel spin axis g_i, body axes (normalised on load)",
    ),
    Param("max_torque_nm", ParamKind.FLOAT, "largest motor torque, N m", bounds=gt(0.0)),
    Param(
        "max_speed_rpm",
        ParamKind.FLOAT,
        "speed limit relative to the body, rpm (the wheel refuses torque beyond it)",
        bounds=gt(0.0),
    ),
    Param(
        "spin_inertia_kgm2",
        ParamKind.FLOAT,
        "inertia about the spin axis, kg m^2 (inside inertia_kgm2, the wheels locked)",
        bounds=gt(0.0),
    ),
    Param(
        "initial_speed_rpm",
        ParamKind.FLOAT,
        "speed relative to the body at t = 0, rpm",
        0.0,
    ),
    Param(
        "fails_at_s",
        ParamKind.FLOAT,
        "from this time on the wheel applies no torque, s (absent: never)",
        None,
        ge(0.0),
    ),
)
"""Per wheel, under ``wheels.<name>.`` (:class:`attitude_core.models.wheel_array.WheelSpec`)."""

PLAN_PARAMETERS = (
    Param("desired_mrp", ParamKind.MRP, "the target's attitude sigma_DN, MRP"),
    Param(
        "dwell_s",
        ParamKind.FLOAT,
        "time the body holds the target within the arrival band before the next, s",
        0.0,
        ge(0.0),
    ),
)
"""Per target, under ``plan.<name>.`` (:class:`attitude_core.config.scenario.PlanTarget`)."""

GROUPS = ("instruments", "bright_objects", "keep_in", "wheels", "plan")
OPTIONAL_GROUPS = ("keep_in", "wheels", "plan")
"""Groups whose ``<group>.names`` may be absent (no member)."""
GROUP_PARAMETERS = {
    "instruments": INSTRUMENT_PARAMETERS,
    "bright_objects": OBJECT_PARAMETERS,
    "keep_in": KEEP_IN_PARAMETERS,
    "wheels": WHEEL_PARAMETERS,
    "plan": PLAN_PARAMETERS,
}
_GROUP_TEXT = {
    "instruments": "names of the instruments",
    "bright_objects": "names of the bright_objects",
    "keep_in": "names of the keep-in cones (absent: none)",
    "wheels": "names of the reaction wheels (absent: actuators.* or an ideal torque)",
    "plan": "names of an observation plan's targets, flown in order (absent: desired_mrp)",
}


def group_names_param(group: str) -> Param:
    """The ``<group>.names`` row: the listed names define the per-name keys (optional,
    default None, for the groups of :data:`OPTIONAL_GROUPS`)."""
    default = None if group in OPTIONAL_GROUPS else REQUIRED
    return Param(f"{group}.names", ParamKind.NAMES, _GROUP_TEXT[group], default)
