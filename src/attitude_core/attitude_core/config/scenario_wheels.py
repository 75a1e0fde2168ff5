"""The scenario's reaction wheels (``wheels.*``) and external torques
(``disturbances.*``) checked and built.

``wheels.*`` and ``actuators.*`` are exclusive: a wheel array's envelope is its
polytope and its momentum, not a box. For now a wheel array is flown by the offline
loop only (:mod:`attitude_core.loop.wheel_loop`), with perfect knowledge and no link;
the external torques need a wheel array (the ideal torque box's plant has none).
"""

from typing import Any

import numpy as np

from attitude_core.config.scenario import ScenarioError
from attitude_core.models.ephemeris import Orbit
from attitude_core.models.link_spec import LinkSpec
from attitude_core.models.sensor_spec import SensorSpec
from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec
from attitude_core.world.disturbances import Disturbances

__all__ = ["parse_wheels", "parse_disturbances"]


def parse_wheels(
    names: tuple[str, ...],
    rows: list[dict[str, Any]],
    values: dict[str, Any],
    source: str,
    sensors: SensorSpec | None,
    link: LinkSpec | None,
) -> WheelArray | None:
    """The wheel array of ``wheels.names`` (None without one)."""
    if not names:
        return None
    given = [k for k in ("actuators.max_torque_nm", "actuators.max_rate_rad_s") if values[k]]
    if given:
        raise ScenarioError(
            source,
            given[0],
            "wheels.* and actuators.* are exclusive: the wheels' torques and momentum are "
            "the envelope (remove actuators.*)",
        )
    for key, what in (("sensors", sensors), ("link", link)):
        if what is not None:
            raise ScenarioError(
                source,
                key,
                f"{key}.* with wheels.* is not supported yet (a wheel array is flown with "
                "perfect knowledge and no link)",
            )
    wheels = tuple(
        WheelSpec(
            name,
            tuple(float(x) for x in np.asarray(d["spin_axis_body"], dtype=float)),  # type: ignore[arg-type]
            float(d["max_torque_nm"]),
            float(d["max_speed_rpm"]) * RPM,
            float(d["spin_inertia_kgm2"]),
            float(d["initial_speed_rpm"] or 0.0) * RPM,
            None if d["fails_at_s"] is None else float(d["fails_at_s"]),
        )
        for name, d in zip(names, rows, strict=True)
    )
    array = WheelArray(wheels)
    problem = array.problem(values["inertia_kgm2"])
    if problem is not None:
        key, _, reason = problem.partition(": ")
        raise ScenarioError(source, key, reason)
    return array


def parse_disturbances(
    values: dict[str, Any], source: str, orbit: Orbit | None, wheels: WheelArray | None
) -> Disturbances | None:
    """The external torques (None: none declared)."""
    gradient = bool(values["disturbances.gravity_gradient"])
    constant = values["disturbances.constant_torque_nm"]
    if not gradient and constant is None:
        return None
    key = "disturbances.gravity_gradient" if gradient else "disturbances.constant_torque_nm"
    if wheels is None:
        raise ScenarioError(source, key, "external torques are flown with wheels.* only")
    if gradient and orbit is None:
        raise ScenarioError(source, key, "the gravity gradient needs the orbit (orbit.*)")
    inertia = tuple(float(x) for x in np.asarray(values["inertia_kgm2"], dtype=float).ravel())
    torque = (0.0, 0.0, 0.0) if constant is None else tuple(float(x) for x in constant)
    return Disturbances(inertia, orbit if gradient else None, torque)  # type: ignore[arg-type]
