"""The scenario's named groups checked and built: instruments, bright objects, keep-in
cones, the orbit, the sensors, the watchdog and the link, and the sky they make (start
and goal outside every keep-out, inside every keep-in)."""

import math
from typing import Any

from attitude_core.config.scenario import (
    BrightObject,
    Instrument,
    KeepIn,
    Scenario,
    ScenarioError,
    frozen_array,
)

__all__ = [
    "parse_instruments",
    "parse_bright_object",
    "parse_keep_in",
    "parse_orbit",
    "parse_sensors",
    "parse_fdir",
    "parse_link",
    "check_sky",
]
from attitude_core.config.scenario_schema import (
    EXCLUSION_PARAMETER,
    LINK_PARAMETERS,
    ORBIT_PARAMETERS,
    SENSOR_PARAMETERS,
    SENSOR_REQUIRED,
)
from attitude_core.fsw.fdir.fdir_config import DEFAULT_TIMEOUT_STEPS, FdirConfig
from attitude_core.models.ephemeris import Orbit
from attitude_core.models.link_spec import LinkSpec
from attitude_core.models.sensor_spec import DEFAULT_BIAS_PRIOR_RAD_S, SensorSpec


def parse_instruments(
    groups: dict[str, tuple[str, ...]],
    rows: list[dict[str, Any]],
    flat: dict[str, object],
    value: Any,
    source: str,
) -> tuple[Instrument, ...]:
    """The instruments, their ``avoids`` lists (default: every object, in list order)
    and their per-object exclusions; an instrument needs ``half_angle_deg`` when one
    object it avoids has no ``exclusion_deg`` of its own."""
    objects = groups["bright_objects"]
    out = []
    for name, d in zip(groups["instruments"], rows, strict=True):
        avoids = objects if d["avoids"] is None else d["avoids"]
        unknown = [o for o in avoids if o not in objects]
        if unknown:
            raise ScenarioError(
                source,
                f"instruments.{name}.avoids",
                f"{unknown[0]!r} is not listed in bright_objects.names",
            )
        own = []
        for o in objects:
            key = f"instruments.{name}.exclusion_deg.{o}"
            if key in flat:
                if o not in avoids:
                    raise ScenarioError(
                        source,
                        key,
                        f"{name!r} does not avoid {o!r} (see instruments.{name}.avoids)",
                    )
                own.append((o, float(value(EXCLUSION_PARAMETER.renamed(key), None))))
        listed = {o for o, _ in own}
        bare = [o for o in avoids if o not in listed]
        if bare and d["half_angle_deg"] is None:
            raise ScenarioError(
                source,
                f"instruments.{name}.half_angle_deg",
                f"missing required key (the exclusion of {', '.join(bare)}, which have no "
                f"instruments.{name}.exclusion_deg.<object>)",
            )
        ordered = tuple(o for o in objects if o in avoids)
        out.append(
            Instrument(
                name, frozen_array(d["boresight_body"]), d["half_angle_deg"], ordered, tuple(own)
            )
        )
    return tuple(out)


def _one_direction(group: str, name: str, d: dict[str, Any], source: str) -> None:
    if (d["direction_inertial"] is None) == (d["ephemeris"] is None):
        raise ScenarioError(
            source,
            f"{group}.{name}",
            "give exactly one of direction_inertial and ephemeris",
        )


def parse_bright_object(name: str, d: dict[str, Any], source: str) -> BrightObject:
    _one_direction("bright_objects", name, d, source)
    rate = d["rate_inertial_rad_s"]
    if rate is not None and d["ephemeris"] is not None:
        raise ScenarioError(
            source,
            f"bright_objects.{name}.rate_inertial_rad_s",
            "turns direction_inertial; an ephemeris body moves by itself",
        )
    direction = d["direction_inertial"]
    return BrightObject(
        name,
        None if direction is None else frozen_array(direction),
        d["ephemeris"],
        None if rate is None else frozen_array(rate),
    )


def parse_keep_in(name: str, d: dict[str, Any], source: str) -> KeepIn:
    _one_direction("keep_in", name, d, source)
    direction = d["direction_inertial"]
    return KeepIn(
        name,
        frozen_array(d["axis_body"]),
        None if direction is None else frozen_array(direction),
        d["max_angle_deg"],
        d["ephemeris"],
    )


def parse_orbit(values: dict[str, Any], source: str) -> Orbit | None:
    """The ``orbit.*`` elements: all six or none, and a physical orbit."""
    keys = [p.key for p in ORBIT_PARAMETERS]
    given = [k for k in keys if values[k] is not None]
    if not given:
        return None
    if len(given) != len(keys):
        missing = [k for k in keys if values[k] is None]
        raise ScenarioError(source, missing[0], "missing: an orbit needs all six orbit.* elements")
    orbit = Orbit(*(float(values[k]) for k in keys))
    problem = orbit.problem()
    if problem is not None:
        raise ScenarioError(source, "orbit", problem)
    return orbit


def parse_sensors(values: dict[str, Any], source: str) -> SensorSpec | None:
    """The ``sensors.*`` keys: none (perfect knowledge), or at least the required ones."""
    keys = [p.key for p in SENSOR_PARAMETERS]
    if all(values[k] is None for k in keys):
        return None
    for key in SENSOR_REQUIRED:
        if values[key] is None:
            raise ScenarioError(source, key, f"missing: sensors need {', '.join(SENSOR_REQUIRED)}")
    arcsec = math.radians(1.0 / 3600.0)
    bias = values["sensors.gyro.bias_rad_s"]
    walk = values["sensors.gyro.bias_walk_rad_s2"]
    prior = values["sensors.gyro.bias_prior_rad_s"]
    outages = values["sensors.star_tracker.outages"] or ()
    max_rate = values["sensors.star_tracker.max_rate_deg_s"]
    spec = SensorSpec(
        seed=int(values["sensors.seed"]),
        star_tracker_noise_rad=tuple(  # type: ignore[arg-type]
            float(x) * arcsec for x in values["sensors.star_tracker.noise_arcsec"]
        ),
        star_tracker_rate_hz=float(values["sensors.star_tracker.rate_hz"]),
        gyro_noise_rad_s=float(values["sensors.gyro.noise_rad_s"]),
        gyro_bias_rad_s=(0.0, 0.0, 0.0) if bias is None else tuple(float(x) for x in bias),  # type: ignore[arg-type]
        gyro_bias_walk_rad_s2=0.0 if walk is None else float(walk),
        gyro_bias_prior_rad_s=DEFAULT_BIAS_PRIOR_RAD_S if prior is None else float(prior),
        star_tracker_outages_s=tuple(
            (float(a), float(a) + float(d))
            for a, d in zip(outages[0::2], outages[1::2], strict=True)
        ),
        star_tracker_max_rate_rad_s=None if max_rate is None else math.radians(float(max_rate)),
        star_tracker_instrument=values["sensors.star_tracker.instrument"],
    )
    problem = spec.problem()
    if problem is not None:
        raise ScenarioError(source, "sensors", problem)
    return spec


def parse_fdir(values: dict[str, Any], source: str, dt_s: float) -> FdirConfig:
    """The ``fdir.*`` limits: ``0 < state_timeout_s < predict_s < safe_after_s``."""
    timeout = values["fdir.state_timeout_s"]
    timeout = DEFAULT_TIMEOUT_STEPS * dt_s if timeout is None else float(timeout)
    predict, safe = float(values["fdir.predict_s"]), float(values["fdir.safe_after_s"])
    if not timeout < predict:
        raise ScenarioError(
            source,
            "fdir.predict_s",
            f"must be above fdir.state_timeout_s ({timeout:g} s), got {predict:g}",
        )
    if not predict < safe:
        raise ScenarioError(
            source,
            "fdir.safe_after_s",
            f"must be above fdir.predict_s ({predict:g} s), got {safe:g}",
        )
    return FdirConfig(timeout, predict, safe)


def parse_link(
    values: dict[str, Any], source: str, fdir: FdirConfig, sensors: SensorSpec | None
) -> LinkSpec | None:
    """The ``link.*`` keys: none (no link), or a link whose slowest state still comes
    within the watchdog's timeout (a lockstep run paces its ticks by that rule)."""
    keys = [p.key for p in LINK_PARAMETERS]
    if all(values[k] is None for k in keys):
        return None
    if sensors is not None:
        raise ScenarioError(
            source,
            "link",
            "a rehearsal link with sensors.* is not supported: the link delays the "
            "simulator's state, and with sensors the loop's state is the estimator's",
        )

    def get(key: str, default: Any) -> Any:
        return default if values[key] is None else values[key]

    raw = get("link.outages", ())
    spec = LinkSpec(
        state_latency_s=float(get("link.state_latency_s", 0.0)),
        jitter_s=float(get("link.jitter_s", 0.0)),
        drop_rate=float(get("link.drop_rate", 0.0)),
        outages=tuple(zip(raw[0::2], raw[1::2], strict=True)),
        seed=int(get("link.seed", 0)),
    )
    problem = spec.problem()
    if problem is not None:
        raise ScenarioError(source, "link", problem)
    slowest = spec.state_latency_s + spec.jitter_s
    if not slowest < fdir.state_timeout_s:
        raise ScenarioError(
            source,
            "link.state_latency_s",
            f"latency plus jitter ({slowest:g} s) must stay below fdir.state_timeout_s "
            f"({fdir.state_timeout_s:g} s): every state would arrive stale",
        )
    return spec


def check_sky(scenario: Scenario, source: str) -> None:
    """Ephemeris bodies need the epoch, ``earth`` the orbit too; the star tracker's
    instrument is a listed one."""
    tracker = None if scenario.sensors is None else scenario.sensors.star_tracker_instrument
    if tracker is not None and tracker not in scenario.instrument_names:
        raise ScenarioError(
            source,
            "sensors.star_tracker.instrument",
            f"{tracker!r} is not a listed instrument {list(scenario.instrument_names)}",
        )
    for group, members in (
        ("bright_objects", scenario.bright_objects),
        ("keep_in", scenario.keep_in),
    ):
        for m in members:
            if m.ephemeris is None:
                continue
            key = f"{group}.{m.name}.ephemeris"
            if scenario.epoch_utc is None:
                raise ScenarioError(source, key, f"{m.ephemeris!r} needs epoch_utc")
            if m.ephemeris == "earth" and scenario.orbit is None:
                raise ScenarioError(source, key, "'earth' (nadir) needs an orbit (orbit.*)")
    for inst in scenario.instruments:
        for o, excl in inst.exclusion_deg:
            if not math.isfinite(excl):
                raise ScenarioError(
                    source, f"instruments.{inst.name}.exclusion_deg.{o}", "must be finite"
                )
