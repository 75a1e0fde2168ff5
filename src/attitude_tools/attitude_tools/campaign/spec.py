"""The campaign SPEC file: parsing and validation, every error naming its key.

A SPEC is YAML with one top-level ``campaign`` mapping (see docs/campaigns.md)::

    campaign:
      name: random_slews
      runs: 1000
      seed: 7
      base_scenario: ../scenarios/case1.yaml   # relative to the SPEC
      sim_time_s: 300.0                        # optional
      dispersions:
        attitudes: uniform
        min_end_margin_deg: 3.0
        instruments: {count: [1, 3], half_angle_deg: [10.0, 35.0]}
        bright_objects: {count: [2, 6]}
        inertia_scale: [0.9, 1.1]              # optional
        initial_rate_rad_s: 0.0                # optional
        actuators: {max_torque_nm: [0.01, 0.1], max_rate_rad_s: [0.02, 0.1]}  # optional
        keep_in: {count: [1, 2], max_angle_deg: [60.0, 120.0]}  # optional
        sky:                                   # optional; the base must have an orbit
          epoch_utc: ["2026-01-01T00:00:00Z", "2027-01-01T00:00:00Z"]
          raan_deg: [0.0, 360.0]
          true_anomaly_deg: [0.0, 360.0]
        link:                                  # optional; a rehearsal link per run (link.*)
          state_latency_s: [0.0, 0.15]
          jitter_s: [0.0, 0.05]
          drop_rate: [0.0, 0.1]
          outages: {count: [0, 2], start_s: [0.0, 90.0], duration_s: [0.0, 3.0]}
        wheels:                                # optional; the base must declare wheels.*
          initial_speed_rpm: [-2000.0, 2000.0] # each wheel's bias, uniform
          failure: {share: 0.25, fails_at_s: [0.0, 60.0]}  # one wheel fails in a share
        sensors:                               # optional; the base must declare sensors.*
          star_tracker_noise_scale: [0.5, 4.0] # times the base's noise_arcsec (its shape kept)
          star_tracker_rate_hz: [1.0, 10.0]
          gyro_noise_rad_s: [1.0e-5, 5.0e-4]   # per sample
          gyro_bias_rad_s: [0.0, 2.0e-3]       # |bias| per axis, random sign
      planner_variants: [improved, paper]

``instruments``, ``bright_objects`` and ``keep_in`` are optional: without one, the base
scenario's group is kept as it is (with its per-object ``exclusion_deg``, ``avoids`` and
``ephemeris`` keys) and no random number is drawn for it, so a SPEC draws the same runs
as before an optional key existed. Drawn bright objects are plain inertial directions,
so they need instruments that avoid them with a ``half_angle_deg``: drawn ones, or base
ones without per-object keys (the SPEC is refused otherwise).

``sky`` draws the epoch uniformly (in whole seconds) between two ISO 8601 UTC
date-times, and the orbit's RAAN and true anomaly uniformly (deg); each of its keys is
optional (absent: the base's value). The other orbit elements come from the base
scenario, which must have an orbit.

``link`` gives each run a rehearsal link (``link.*``) with its own ``link.seed`` and,
per key given, a latency, a jitter and a loss rate drawn uniformly, and ``count``
outages, each starting uniformly in ``start_s`` (s) for ``duration_s`` (s); the most
latency plus jitter must stay below the base's ``fdir.state_timeout_s``.

``wheels`` needs a base scenario with ``wheels.*``: per key given, each wheel's initial
speed (rpm, uniform; within every wheel's speed limit), and in a ``share`` of the runs
one wheel (uniform among them) failing at a time uniform in ``fails_at_s``.

``sensors`` needs a base scenario with ``sensors.*``: each run gets its own
``sensors.seed`` and, per key given, the star tracker's noise (the base's 3-vector times
one uniform factor), its rate (Hz), the gyro's white noise (rad/s per sample) and its
bias (each axis: a magnitude uniform in the range, a random sign); the rest is the
base's.

``goal_near_keep_out: {offset_deg: [lo, hi]}`` places each run's goal just outside a
keep-out: after the rest is drawn, one keep-out pair (an instrument and an object it
avoids, uniform among the sky's pairs) and an offset (uniform, deg) are drawn, and the
goal is turned by the smallest rotation that puts that pair's margin at the offset at
``t = 0``. The goal is then exempt from ``min_end_margin_deg`` (the start is not); a
draw whose goal lies nearer another constraint than the offset at ``t = 0`` is redrawn.
The moving sky may cover such a goal later in the run: that is what it tests. Not with
``plan``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import yaml

from attitude_core.config.scenario import Scenario, ScenarioError
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.models.ephemeris import parse_epoch_utc
from attitude_core.models.wheel_array import RPM
from attitude_core.yamlio import load_strict

__all__ = [
    "SpecError",
    "Range",
    "CampaignSpec",
    "load_spec",
    "utc_text",
    "VARIANTS",
    "MAX_REDRAWS",
]

VARIANTS = ("improved", "paper")
MAX_REDRAWS = 10_000  # per run: a dispersion that can never give a valid draw fails
_POSIX_0 = datetime(1970, 1, 1, tzinfo=UTC)
_SECOND = timedelta(seconds=1)


class SpecError(ValueError):
    """A SPEC problem: ``key`` is the dotted key (``campaign.dispersions.instruments``)."""

    def __init__(self, source: str, key: str | None, reason: str) -> None:
        self.source, self.key, self.reason = source, key, reason
        where = f"'{key}'" if key else "the file"
        super().__init__(f"{source}: {where}: {reason}")


@dataclass(frozen=True)
class Range:
    """A closed interval ``[lo, hi]`` to draw from uniformly."""

    lo: float
    hi: float


@dataclass(frozen=True)
class CampaignSpec:
    name: str
    runs: int
    seed: int
    base_scenario: str  # absolute path
    sim_time_s: float | None
    min_end_margin_deg: float
    # Instruments and bright objects drawn per run (None: the base scenario's).
    instrument_count: tuple[int, int] | None
    half_angle_deg: Range | None
    object_count: tuple[int, int] | None
    inertia_scale: Range | None
    initial_rate_std_rad_s: float
    max_torque_nm: Range | None
    max_rate_rad_s: Range | None
    planner_variants: tuple[str, ...]
    source: str
    # Keep-in cones drawn per run (None: the base scenario's, drawing nothing).
    keep_in_count: tuple[int, int] | None = None
    keep_in_max_angle_deg: Range | None = None
    # The sky drawn per run (None: the base scenario's): the epoch in whole POSIX
    # seconds (UTC, no leap seconds), the orbit's RAAN and true anomaly in deg.
    sky_epoch_s: tuple[int, int] | None = None
    sky_raan_deg: Range | None = None
    sky_true_anomaly_deg: Range | None = None
    # The sensors drawn per run (False: the base's, no seed drawn).
    sensors: bool = False
    star_tracker_noise_scale: Range | None = None
    star_tracker_rate_hz: Range | None = None
    gyro_noise_rad_s: Range | None = None
    gyro_bias_rad_s: Range | None = None
    # The rehearsal link drawn per run (False: the base's, no seed drawn).
    link: bool = False
    link_latency_s: Range | None = None
    link_jitter_s: Range | None = None
    link_drop_rate: Range | None = None
    outage_count: tuple[int, int] | None = None
    outage_start_s: Range | None = None
    outage_duration_s: Range | None = None
    # The wheels' biases and failure drawn per run (False: the base's wheels as they are).
    wheels: bool = False
    wheel_speed_rpm: Range | None = None
    wheel_failure_share: float | None = None
    wheel_fails_at_s: Range | None = None
    # An observation plan drawn per run (0: the base's one goal): this many targets, each
    # uniform over SO(3) like the goal, with a dwell uniform in plan_dwell_s.
    plan_targets: int = 0
    plan_dwell_s: Range | None = None
    # The goal placed this far outside a drawn keep-out at t = 0 (None: not placed).
    goal_near_keep_out_deg: Range | None = None

    @property
    def tasks(self) -> list[tuple[int, str]]:
        """Every ``(run, variant)`` of the campaign, in order."""
        return [(i, v) for i in range(self.runs) for v in self.planner_variants]

    @property
    def drawn_groups(self) -> tuple[str, ...]:
        """The scenario groups drawn per run (the others are the base scenario's)."""
        drawn = {
            "instruments": self.instrument_count is not None,
            "bright_objects": self.object_count is not None,
            "keep_in": self.keep_in_count is not None,
        }
        return tuple(g for g, d in drawn.items() if d)


def utc_text(posix_s: int) -> str:
    """``YYYY-MM-DDThh:mm:ssZ`` of whole POSIX seconds."""
    return (_POSIX_0 + posix_s * _SECOND).strftime("%Y-%m-%dT%H:%M:%SZ")


_TOP = {"name", "runs", "seed", "base_scenario", "sim_time_s", "dispersions", "planner_variants"}
_DISPERSIONS = {
    "attitudes",
    "min_end_margin_deg",
    "instruments",
    "bright_objects",
    "inertia_scale",
    "initial_rate_rad_s",
    "actuators",
    "keep_in",
    "sky",
    "sensors",
    "link",
    "wheels",
    "plan",
    "goal_near_keep_out",
}
_PLAN = {"targets", "dwell_s"}
_SKY = {"epoch_utc", "raan_deg", "true_anomaly_deg"}
_SENSORS = {
    "star_tracker_noise_scale",
    "star_tracker_rate_hz",
    "gyro_noise_rad_s",
    "gyro_bias_rad_s",
}
_LINK = {"state_latency_s", "jitter_s", "drop_rate", "outages"}
_OUTAGES = {"count", "start_s", "duration_s"}
_WHEELS = {"initial_speed_rpm", "failure"}
_FAILURE = {"share", "fails_at_s"}
# Keys of an instrument that name the base scenario's bright objects.
_PER_OBJECT = ("exclusion_deg", "avoids")


class _Reader:
    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str | None, reason: str) -> SpecError:
        return SpecError(self.source, key, reason)

    def mapping(self, value: Any, key: str, known: set[str]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(key, f"expected a mapping, got {type(value).__name__}")
        for k in value:
            if k not in known:
                raise self.fail(f"{key}.{k}", f"unknown key; known: {sorted(known)}")
        return value

    def number(self, value: Any, key: str, lo: float = -math.inf, lo_open: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"expected a number, got {value!r}")
        x = float(value)
        if not math.isfinite(x):
            raise self.fail(key, "must be finite")
        if x < lo or (lo_open and x == lo):
            raise self.fail(key, f"must be {'>' if lo_open else '>='} {lo:g}, got {x:g}")
        return x

    def integer(self, value: Any, key: str, lo: int) -> int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise self.fail(key, f"expected an integer, got {value!r}")
        if value < lo:
            raise self.fail(key, f"must be >= {lo}, got {value}")
        return value

    def pair(self, value: Any, key: str, lo: float, lo_open: bool = False) -> Range:
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(key, f"expected [low, high], got {value!r}")
        a = self.number(value[0], key, lo, lo_open)
        b = self.number(value[1], key, lo, lo_open)
        if a > b:
            raise self.fail(key, f"low {a:g} is above high {b:g}")
        return Range(a, b)

    def epoch(self, value: Any, key: str) -> datetime:
        """An ISO 8601 UTC date-time (a YAML timestamp too), timezone-aware."""
        if isinstance(value, datetime):
            value = value.isoformat()
        if not isinstance(value, str):
            raise self.fail(key, f"expected an ISO 8601 UTC date-time string, got {value!r}")
        try:
            parse_epoch_utc(value)  # the scenario loader's rules (format, year range)
            when = datetime.fromisoformat(value.strip().replace("Z", "+00:00"))
        except ValueError as exc:
            raise self.fail(key, str(exc)) from None
        return when.replace(tzinfo=UTC) if when.tzinfo is None else when.astimezone(UTC)

    def epoch_range(self, value: Any, key: str) -> tuple[int, int]:
        """``[from, to]`` as the first and last whole POSIX second within it."""
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(key, f"expected [from, to] (ISO 8601 UTC date-times), got {value!r}")
        a, b = self.epoch(value[0], key), self.epoch(value[1], key)
        if a > b:
            raise self.fail(key, f"from {a.isoformat()} is after to {b.isoformat()}")
        lo, hi = -((_POSIX_0 - a) // _SECOND), (b - _POSIX_0) // _SECOND
        if lo > hi:
            raise self.fail(key, "the range holds no whole second")
        return lo, hi

    def count(self, value: Any, key: str, lo: int = 1) -> tuple[int, int]:
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(key, f"expected [min, max], got {value!r}")
        a, b = self.integer(value[0], key, lo), self.integer(value[1], key, lo)
        if a > b:
            raise self.fail(key, f"min {a} is above max {b}")
        return a, b


def load_spec(path: str | Path) -> CampaignSpec:
    """Read and validate a SPEC file (:class:`SpecError` naming the key on any problem)."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(source, None, f"cannot read file: {exc}") from exc
    try:
        doc = load_strict(text)
    except yaml.YAMLError as exc:
        raise SpecError(source, None, f"not valid YAML: {exc}") from exc
    r = _Reader(source)
    if not isinstance(doc, dict) or list(doc) != ["campaign"]:
        raise r.fail(None, "expected one top-level key 'campaign'")
    c = r.mapping(doc["campaign"], "campaign", _TOP)
    for required in ("name", "runs", "seed", "base_scenario", "dispersions"):
        if required not in c:
            raise r.fail(f"campaign.{required}", "missing")
    name = c["name"]
    if not isinstance(name, str) or not name.strip():
        raise r.fail("campaign.name", f"expected a non-empty string, got {name!r}")
    runs = r.integer(c["runs"], "campaign.runs", 1)
    seed = r.integer(c["seed"], "campaign.seed", 0)
    base = c["base_scenario"]
    if not isinstance(base, str):
        raise r.fail("campaign.base_scenario", f"expected a path, got {base!r}")
    base_path = (Path(path).resolve().parent / base).resolve()
    try:
        base_scenario = load_scenario(base_path)
    except ScenarioError as exc:
        raise r.fail("campaign.base_scenario", f"not a valid scenario: {exc}") from exc
    sim_time = None
    if c.get("sim_time_s") is not None:
        sim_time = r.number(c["sim_time_s"], "campaign.sim_time_s", 0.0, lo_open=True)
    d = r.mapping(c["dispersions"], "campaign.dispersions", _DISPERSIONS)
    key = "campaign.dispersions"
    if d.get("attitudes", "uniform") != "uniform":
        raise r.fail(f"{key}.attitudes", f"only 'uniform' is known, got {d['attitudes']!r}")
    margin = r.number(d.get("min_end_margin_deg", 3.0), f"{key}.min_end_margin_deg", 0.0)
    inst_count = half = obj_count = None
    if d.get("instruments") is not None:
        inst = r.mapping(d["instruments"], f"{key}.instruments", {"count", "half_angle_deg"})
        inst_count = r.count(inst.get("count", [1, 3]), f"{key}.instruments.count")
        half = r.pair(
            inst.get("half_angle_deg", [10.0, 35.0]), f"{key}.instruments.half_angle_deg", 0.0, True
        )
        if half.hi >= 90.0:
            raise r.fail(f"{key}.instruments.half_angle_deg", "must be below 90 deg")
    if d.get("bright_objects") is not None:
        objs = r.mapping(d["bright_objects"], f"{key}.bright_objects", {"count"})
        obj_count = r.count(objs.get("count", [2, 6]), f"{key}.bright_objects.count")
        if inst_count is None:
            _check_kept_instruments(r, base_scenario, f"{key}.bright_objects")
    scale = None
    if d.get("inertia_scale") is not None:
        scale = r.pair(d["inertia_scale"], f"{key}.inertia_scale", 0.0, lo_open=True)
    rate_std = r.number(d.get("initial_rate_rad_s", 0.0), f"{key}.initial_rate_rad_s", 0.0)
    torque = rate = None
    if d.get("actuators") is not None:
        act = r.mapping(d["actuators"], f"{key}.actuators", {"max_torque_nm", "max_rate_rad_s"})
        if act.get("max_torque_nm") is not None:
            torque = r.pair(act["max_torque_nm"], f"{key}.actuators.max_torque_nm", 0.0, True)
        if act.get("max_rate_rad_s") is not None:
            rate = r.pair(act["max_rate_rad_s"], f"{key}.actuators.max_rate_rad_s", 0.0, True)
    keep_in_count = keep_in_angle = None
    if d.get("keep_in") is not None:
        ki = r.mapping(d["keep_in"], f"{key}.keep_in", {"count", "max_angle_deg"})
        for required in ("count", "max_angle_deg"):
            if required not in ki:
                raise r.fail(f"{key}.keep_in.{required}", "missing")
        keep_in_count = r.count(ki["count"], f"{key}.keep_in.count", lo=0)
        keep_in_angle = r.pair(ki["max_angle_deg"], f"{key}.keep_in.max_angle_deg", 0.0, True)
        if keep_in_angle.hi >= 180.0:
            raise r.fail(f"{key}.keep_in.max_angle_deg", "must be below 180 deg")
    epoch = raan = anomaly = None
    if d.get("sky") is not None:
        sky = r.mapping(d["sky"], f"{key}.sky", _SKY)
        if not sky:
            raise r.fail(f"{key}.sky", f"give at least one of {sorted(_SKY)}")
        if base_scenario.orbit is None:
            raise r.fail(
                f"{key}.sky",
                f"the base scenario {base} has no orbit (orbit.*): the drawn sky takes its "
                "other orbit elements from it",
            )
        if sky.get("epoch_utc") is not None:
            epoch = r.epoch_range(sky["epoch_utc"], f"{key}.sky.epoch_utc")
        if sky.get("raan_deg") is not None:
            raan = r.pair(sky["raan_deg"], f"{key}.sky.raan_deg", -math.inf)
        if sky.get("true_anomaly_deg") is not None:
            anomaly = r.pair(sky["true_anomaly_deg"], f"{key}.sky.true_anomaly_deg", -math.inf)
    sensors = False
    sensor_ranges: dict[str, Any] = dict.fromkeys(_SENSORS)  # Range | None each
    if d.get("sensors") is not None:
        given = r.mapping(d["sensors"], f"{key}.sensors", _SENSORS)
        if base_scenario.sensors is None:
            raise r.fail(
                f"{key}.sensors",
                f"the base scenario {base} declares no sensors (sensors.*): the drawn "
                "sensors take the rest of their declaration from it",
            )
        sensors = True
        for field, value in given.items():
            positive = field in ("star_tracker_noise_scale", "star_tracker_rate_hz")
            sensor_ranges[field] = r.pair(value, f"{key}.sensors.{field}", 0.0, positive)
    link = _read_link(r, d.get("link"), f"{key}.link", base_scenario)
    link.update(_read_wheels(r, d.get("wheels"), f"{key}.wheels", base_scenario, str(base)))
    link.update(_read_plan(r, d.get("plan"), f"{key}.plan", base_scenario, str(base)))
    if d.get("goal_near_keep_out") is not None:
        near_key = f"{key}.goal_near_keep_out"
        near = r.mapping(d["goal_near_keep_out"], near_key, {"offset_deg"})
        if "offset_deg" not in near:
            raise r.fail(f"{near_key}.offset_deg", "missing")
        if d.get("plan") is not None:
            raise r.fail(near_key, "places the one goal: not with plan")
        link["goal_near_keep_out_deg"] = r.pair(
            near["offset_deg"], f"{near_key}.offset_deg", 0.0, True
        )
    variants = c.get("planner_variants", ["improved"])
    if (
        not isinstance(variants, list)
        or not variants
        or any(v not in VARIANTS for v in variants)
        or len(set(variants)) != len(variants)
    ):
        raise r.fail(
            "campaign.planner_variants",
            f"expected distinct names from {list(VARIANTS)}, got {variants!r}",
        )
    spec = CampaignSpec(
        name=name,
        runs=runs,
        seed=seed,
        base_scenario=str(base_path),
        sim_time_s=sim_time,
        min_end_margin_deg=margin,
        instrument_count=inst_count,
        half_angle_deg=half,
        object_count=obj_count,
        inertia_scale=scale,
        initial_rate_std_rad_s=rate_std,
        max_torque_nm=torque,
        max_rate_rad_s=rate,
        planner_variants=tuple(variants),
        source=source,
        keep_in_count=keep_in_count,
        keep_in_max_angle_deg=keep_in_angle,
        sky_epoch_s=epoch,
        sky_raan_deg=raan,
        sky_true_anomaly_deg=anomaly,
        sensors=sensors,
        **sensor_ranges,
    )
    return dataclasses.replace(spec, **link)


def _read_link(r: _Reader, value: Any, key: str, base: Scenario) -> dict[str, Any]:
    """The ``link`` dispersions as :class:`CampaignSpec` fields (none: ``{}``)."""
    if value is None:
        return {}
    given = r.mapping(value, key, _LINK)
    out: dict[str, Any] = {"link": True}
    for name, field in (
        ("state_latency_s", "link_latency_s"),
        ("jitter_s", "link_jitter_s"),
        ("drop_rate", "link_drop_rate"),
    ):
        if given.get(name) is not None:
            out[field] = r.pair(given[name], f"{key}.{name}", 0.0)
    drop = out.get("link_drop_rate")
    if drop is not None and drop.hi >= 1.0:
        raise r.fail(f"{key}.drop_rate", f"must stay below 1, got up to {drop.hi}")
    slowest = sum(out[f].hi for f in ("link_latency_s", "link_jitter_s") if f in out)
    timeout = base.watchdog.state_timeout_s
    if slowest >= timeout:
        raise r.fail(
            f"{key}.state_latency_s",
            f"latency plus jitter up to {slowest:g} s: must stay below the base's "
            f"fdir.state_timeout_s ({timeout:g} s)",
        )
    if given.get("outages") is not None:
        outages = r.mapping(given["outages"], f"{key}.outages", _OUTAGES)
        if any(outages.get(k) is None for k in _OUTAGES):
            raise r.fail(f"{key}.outages", f"give {sorted(_OUTAGES)}")
        out["outage_count"] = r.count(outages["count"], f"{key}.outages.count", lo=0)
        out["outage_start_s"] = r.pair(outages["start_s"], f"{key}.outages.start_s", 0.0)
        duration = r.pair(outages["duration_s"], f"{key}.outages.duration_s", 0.0)
        out["outage_duration_s"] = duration
    return out


def _read_wheels(
    r: _Reader, value: Any, key: str, base: Scenario, base_name: str
) -> dict[str, Any]:
    """The ``wheels`` dispersions as :class:`CampaignSpec` fields (none: ``{}``)."""
    if value is None:
        return {}
    given = r.mapping(value, key, _WHEELS)
    if base.wheels is None:
        raise r.fail(key, f"the base scenario {base_name} declares no wheels (wheels.*)")
    out: dict[str, Any] = {"wheels": True}
    if given.get("initial_speed_rpm") is not None:
        speeds = r.pair(given["initial_speed_rpm"], f"{key}.initial_speed_rpm", -math.inf)
        top = float(min(base.wheels.max_speed)) / RPM
        if max(abs(speeds.lo), abs(speeds.hi)) > top:
            raise r.fail(
                f"{key}.initial_speed_rpm",
                f"must stay within every wheel's max_speed_rpm ({top:g})",
            )
        out["wheel_speed_rpm"] = speeds
    if given.get("failure") is not None:
        failure = r.mapping(given["failure"], f"{key}.failure", _FAILURE)
        if any(failure.get(k) is None for k in _FAILURE):
            raise r.fail(f"{key}.failure", f"give {sorted(_FAILURE)}")
        share = r.number(failure["share"], f"{key}.failure.share", 0.0)
        if share > 1.0:
            raise r.fail(f"{key}.failure.share", f"must be <= 1, got {share:g}")
        out["wheel_failure_share"] = share
        out["wheel_fails_at_s"] = r.pair(failure["fails_at_s"], f"{key}.failure.fails_at_s", 0.0)
    return out


def _read_plan(r: _Reader, value: Any, key: str, base: Scenario, base_name: str) -> dict[str, Any]:
    """The ``plan`` dispersions as :class:`CampaignSpec` fields (none: ``{}``)."""
    if value is None:
        return {}
    given = r.mapping(value, key, _PLAN)
    if any(given.get(k) is None for k in _PLAN):
        raise r.fail(key, f"give {sorted(_PLAN)}")
    targets = given["targets"]
    if isinstance(targets, bool) or not isinstance(targets, int) or not 1 <= targets <= 20:
        raise r.fail(f"{key}.targets", f"must be an integer in [1, 20], got {targets!r}")
    if base.wheels is not None or base.link is not None:
        raise r.fail(
            key, f"the base scenario {base_name} has wheels.* or link.*: plans fly without"
        )
    return {
        "plan_targets": targets,
        "plan_dwell_s": r.pair(given["dwell_s"], f"{key}.dwell_s", 0.0),
    }


def _check_kept_instruments(r: _Reader, base: Scenario, key: str) -> None:
    """Drawn bright objects with the base's instruments: each instrument must avoid every
    object by its ``half_angle_deg``, naming none of the base's objects."""
    flat = flatten_parameters(
        load_strict(Path(base.source).read_text(encoding="utf-8"))["/**"]["ros__parameters"]
    )
    for inst in base.instruments:
        prefix = f"instruments.{inst.name}."
        named = [k for k in flat if k.startswith(prefix) and k.split(".")[2] in _PER_OBJECT]
        if inst.half_angle_deg is None or named:
            what = f"has {named[0]}" if named else "has no half_angle_deg"
            raise r.fail(
                key,
                f"the base scenario's instrument {inst.name!r} {what}: drawn bright objects "
                "need instruments that avoid them by a half-angle (give "
                "dispersions.instruments too)",
            )
