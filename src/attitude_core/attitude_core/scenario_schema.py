"""The scenario's parameter table: every scenario key as one :class:`Param` row.

The loader (:mod:`attitude_core.scenario`) validates with these rows and the nodes
declare them (``attitude_ros.params``); each node declares only the rows it reads
(:mod:`attitude_core.node_parameters`). Per listed name, the rows of
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

from .parameters import REQUIRED, Bounds, ByVariant, Param, ge, gt

__all__ = [
    "SCENARIO_PARAMETERS",
    "GROUP_PARAMETERS",
    "INSTRUMENT_PARAMETERS",
    "OBJECT_PARAMETERS",
    "KEEP_IN_PARAMETERS",
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


def _positive_vector(v: Any) -> str | None:
    if not all(float(x) > 0.0 for x in v):
        return f"every element must be > 0, got {[float(x) for x in v]}"
    return None


SCENARIO_PARAMETERS = (
    Param("scenario_name", "name", "name used in outputs ([A-Za-z][A-Za-z0-9_]*)"),
    Param("sim_time_s", "float", "simulated time, s (>= dt_s)", bounds=gt(0.0)),
    Param("dt_s", "float", "guidance, control and integration step, s", bounds=gt(0.0)),
    Param(
        "inertia_kgm2",
        "matrix3",
        "inertia J about the body axes, kg m^2, row-major 3x3, SPD (eq. 4)",
        check=_rigid_body,
    ),
    Param(
        "initial_mrp",
        "mrp",
        "initial attitude sigma_BN(0), MRP (|sigma| > 1 taken as its shadow set)",
    ),
    Param("desired_mrp", "mrp", "desired attitude sigma_d = sigma_DN, MRP"),
    Param("initial_rate_rad_s", "vec3", "initial body rate omega_BN(0), body axes, rad/s"),
    Param(
        "controller.kp_over_j",
        "float",
        "proportional gain Kp = kp_over_j J, 1/s^2 (paper 5.5)",
        5.5,
        gt(0.0),
    ),
    Param(
        "controller.kd_over_j",
        "float",
        "derivative gain Kd = kd_over_j J, 1/s (paper 3.1)",
        3.1,
        gt(0.0),
    ),
    Param(
        "planner.variant",
        "str",
        "FEPF variant whose defaults apply",
        "improved",
        choices=("improved", "paper"),
    ),
    Param(
        "planner.direction_axis",
        "str",
        "repulsive rotation axis (eq. 9)",
        ByVariant("goal_plane", "paper"),
        choices=("goal_plane", "paper"),
    ),
    Param(
        "planner.gamma_deg",
        "float",
        "repulsive rotation angle gamma, deg",
        ByVariant(60.0, 10.0),
        Bounds(0.0, 180.0, hi_open=True),
    ),
    Param(
        "planner.fis_attractive",
        "data_file",
        "attractive FIS data (packaged name or path)",
        ByVariant("fis_attractive.yaml", "fis_attractive_paper.yaml"),
    ),
    Param(
        "planner.fis_repulsive",
        "data_file",
        "repulsive FIS data (packaged name or path)",
        ByVariant("fis_repulsive.yaml", "fis_repulsive_paper.yaml"),
    ),
    Param(
        "planner.max_attractive_rate_mrp_s",
        "float",
        "attractive speed scale, MRP/s",
        ByVariant(0.03, 0.03),
        gt(0.0),
    ),
    Param(
        "planner.max_repulsive_rate_mrp_s",
        "float",
        "repulsive speed scale, MRP/s",
        ByVariant(0.03, 0.03),
        ge(0.0),
    ),
    Param(
        "planner.influence_distance_mrp",
        "float",
        "obstacle influence distance, MRP",
        ByVariant(0.3, 0.3),
        gt(0.0),
    ),
    Param(
        "planner.safety_margin_deg",
        "float",
        "buffer added to every cone for planning, deg",
        ByVariant(2.0, 2.0),
        Bounds(0.0, 45.0, hi_open=True),
    ),
    Param(
        "planner.max_accel_mrp_s2",
        "float",
        "target acceleration bound, MRP/s^2 (0: none)",
        ByVariant(0.01, 0.0),
        ge(0.0),
    ),
    Param(
        "planner.terminal_time_constant_s",
        "float",
        "terminal rate time constant, s (0: none)",
        ByVariant(2.0, 0.0),
        ge(0.0),
    ),
    Param(
        "planner.goal_tolerance_mrp",
        "float",
        "goal capture distance, MRP",
        ByVariant(1.0e-4, 1.0e-4),
        gt(0.0),
    ),
    Param(
        "planner.stuck_timeout_s",
        "float",
        "no-progress time before status stuck, s",
        ByVariant(10.0, 10.0),
        gt(0.0),
    ),
    Param(
        "planner.obstacle_samples",
        "int",
        "rim samples per keep-out cone",
        ByVariant(180, 180),
        Bounds(16, 100_000),
    ),
    Param(
        "planner.planning_frame",
        "str",
        "MRPs the FEPF is formed in: 'target' (relative to the current target: the short "
        "way) or 'inertial' (sigma_BN, the paper's)",
        ByVariant("target", "inertial"),
        choices=("target", "inertial"),
    ),
    Param(
        "planner.global_route",
        "bool",
        "follow a global route's waypoints (false: the FEPF alone; feasibility is "
        "checked either way)",
        ByVariant(True, False),
    ),
    Param(
        "planner.roadmap_nodes",
        "int",
        "attitudes of the global route's roadmap (its resolution)",
        ByVariant(4096, 4096),
        Bounds(256, 262_144),
    ),
    Param(
        "actuators.max_torque_nm",
        "vec3",
        "per-body-axis torque bound of the actuators, N m (each > 0; absent: unlimited)",
        None,
        check=_positive_vector,
    ),
    Param(
        "actuators.max_rate_rad_s",
        "float",
        "body-rate bound the guidance must respect, rad/s (absent: unlimited)",
        None,
        gt(0.0),
    ),
    Param("arrival.attitude_tol_deg", "float", "arrival: attitude error bound, deg", 0.5, gt(0.0)),
    Param("arrival.rate_tol_rad_s", "float", "arrival: body rate bound, rad/s", 1.0e-3, gt(0.0)),
)
"""Top-level, controller, planner and arrival keys, in validation order."""

INSTRUMENT_PARAMETERS = (
    Param("boresight_body", "unit3", "instrument boresight s_i, body axes, unit vector"),
    Param(
        "half_angle_deg",
        "float",
        "keep-out half-angle beta_i, deg",
        bounds=Bounds(0.0, 90.0, lo_open=True, hi_open=True),
    ),
)
OBJECT_PARAMETERS = (
    Param("direction_inertial", "unit3", "bright-object direction c_j, inertial axes, unit vector"),
)
KEEP_IN_PARAMETERS = (
    Param("axis_body", "unit3", "keep-in body axis a_k, body axes, unit vector"),
    Param(
        "direction_inertial",
        "unit3",
        "direction d_k the axis must stay near, inertial axes, unit vector",
    ),
    Param(
        "max_angle_deg",
        "float",
        "largest angle gamma_k between the axis and the direction, deg",
        bounds=Bounds(0.0, 180.0, lo_open=True, hi_open=True),
    ),
)
GROUPS = ("instruments", "bright_objects", "keep_in")
OPTIONAL_GROUPS = ("keep_in",)
"""Groups whose ``<group>.names`` may be absent (no member)."""
GROUP_PARAMETERS = {
    "instruments": INSTRUMENT_PARAMETERS,
    "bright_objects": OBJECT_PARAMETERS,
    "keep_in": KEEP_IN_PARAMETERS,
}
_GROUP_TEXT = {
    "instruments": "names of the instruments",
    "bright_objects": "names of the bright_objects",
    "keep_in": "names of the keep-in cones (absent: none)",
}


def group_names_param(group: str) -> Param:
    """The ``<group>.names`` row: the listed names define the per-name keys (optional,
    default None, for the groups of :data:`OPTIONAL_GROUPS`)."""
    default = None if group in OPTIONAL_GROUPS else REQUIRED
    return Param(f"{group}.names", "names", _GROUP_TEXT[group], default)
