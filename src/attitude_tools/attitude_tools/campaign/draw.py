"""One dispersed scenario per run index: run ``i`` depends only on ``(seed, i)``.

The random stream of run ``i`` is ``numpy.random.default_rng([seed, i])``, so a run
draws the same scenario whatever the worker, the partitioning or the order. Every draw
goes through the one scenario loader (``parse_scenario``, given the values a reproducer
file holds: :func:`scenario_text` read back by ``loads_scenario`` gives the same, without
a YAML round trip per draw); a draw whose start or goal
lies within ``min_end_margin_deg`` of a constraint boundary (a keep-out cone, or the rim
of a keep-in cone), or that the loader refuses, is counted and redrawn.

The end-margin check (:func:`_end_margin_deg`) has two paths. On a *plain* draw (every
bright object a fixed inertial direction, every instrument avoiding every object by its
``half_angle_deg``, every keep-in direction fixed) it is checked first, on the drawn
values, before the loader. On a draw with a real sky (ephemeris bodies, turning objects,
per-object ``exclusion_deg`` or ``avoids``) it is checked after the loader, on the
loaded scenario's sky (:meth:`attitude_core.models.sky.Sky.constraint_margins_deg`): the
start at ``t = 0``, the goal at every 5 s over ``[0, sim_time_s]``, so that a goal the
moving sky covers during the run is redrawn: campaigns judge the guidance on goals that
stay clear (blocked goals: ``scenarios/leo_goal_blocked.yaml``,
``tests/core/test_moving_sky_guidance.py``). On that path a start inside a cone is
refused by the loader (counted as refused, not as too close).

The stream is consumed in a fixed order, each optional dispersion only when the SPEC
gives it:

1. the instrument count, then the bright-object count (``instruments``,
   ``bright_objects``; absent: the base scenario's group, nothing drawn);
2. per drawn instrument a boresight and a half-angle, then per drawn object a direction;
3. start and goal (uniform on SO(3));
4. inertia scales (``inertia_scale``), the initial rate (``initial_rate_rad_s``), the
   actuator limits (``actuators``: torque per axis, then rate);
5. the keep-in cones (``keep_in``: count, then per cone a body axis, an inertial
   direction, both uniform on the unit sphere, and a largest angle uniform in
   ``max_angle_deg``);
6. the sky (``sky``): the epoch (a whole second, uniform between the range's ends), the
   orbit's RAAN, then its true anomaly (uniform, deg);
7. the sensors (``sensors``): the run's ``sensors.seed``, then per key given the star
   tracker's noise factor, its rate, the gyro's noise and, per axis, its bias magnitude
   and sign;
8. the link (``link``): the run's ``link.seed``, then per key given the latency, the
   jitter and the loss rate, then the outage count and each outage's duration and start;
9. the wheels (``wheels``): per base wheel its initial speed, then with a failure share
   a uniform draw deciding the failure, the failed wheel and its time;
10. the plan (``plan``): per target an attitude and a dwell;
11. the goal near a keep-out (``goal_near_keep_out``): a uniform number choosing the
    keep-out pair, then the offset; the goal is turned onto it once the draw is loaded
    (:func:`attitude_tools.campaign.near_keep_out.goal_at_margin`), exempt from the
    end-margin check (the start is not), and redrawn if another constraint is nearer
    than the offset at ``t = 0``.

A value range whose ends are equal gives its end and draws nothing (a count range is
always drawn). An optional dispersion that the SPEC does not give draws nothing, and new
ones come last, so adding one to the list never changes the runs of a SPEC without it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from attitude_core.config.scenario import Scenario, ScenarioError
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import parse_scenario
from attitude_core.config.scenario_loader import scenario_yaml as to_yaml
from attitude_core.config.scenario_schema import GROUPS
from attitude_core.models.cone_math import margins_deg_from_dcm
from attitude_core.yamlio import load_strict

from .near_keep_out import goal_at_margin, keep_out_pairs
from .spec import MAX_REDRAWS, CampaignSpec, utc_text

__all__ = ["Draw", "base_parameters", "draw_run", "scenario_text", "as_read_back", "GOAL_SAMPLE_S"]

GOAL_SAMPLE_S = 5.0
"""Spacing of the times at which a drawn goal's margin is checked on a moving sky, s."""
# Keys of a group member that only the loaded scenario's sky can measure.
_SKY_KEYS = ("ephemeris", "rate_inertial_rad_s", "exclusion_deg", "avoids")


@dataclass(frozen=True)
class Draw:
    """The drawn scenario of one run, its parameters, and the redraws it took."""

    index: int
    flat: dict[str, Any]
    scenario: Scenario
    refused_by_loader: int
    too_close_to_a_cone: int


def base_parameters(spec: CampaignSpec) -> dict[str, Any]:
    """The base scenario's parameters, dotted; data-file paths made absolute (read once
    per process: every task of a worker shares the base)."""
    return dict(_base_parameters(spec.base_scenario))


@functools.lru_cache(maxsize=8)
def _base_parameters(base_scenario: str) -> dict[str, Any]:
    path = Path(base_scenario)
    doc = load_strict(path.read_text(encoding="utf-8"))
    flat = flatten_parameters(doc["/**"]["ros__parameters"], str(path))
    for key in ("planner.fis_attractive", "planner.fis_repulsive"):
        value = flat.get(key)
        if isinstance(value, str) and "/" in value:
            flat[key] = str((path.parent / value).resolve())
    return flat


def _unit(rng: np.random.Generator) -> list[float]:
    v = rng.normal(size=3)
    return [float(x) for x in v / np.linalg.norm(v)]


def _uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi)) if hi > lo else float(lo)


def _candidate(
    spec: CampaignSpec, base: dict[str, Any], i: int, rng: np.random.Generator
) -> dict[str, Any]:
    # Drawn groups replace the base's; a group the SPEC does not disperse is kept.
    drawn = spec.drawn_groups
    flat = {k: v for k, v in base.items() if k.split(".", 1)[0] not in drawn}
    flat["scenario_name"] = f"{spec.name}_{i}"
    if spec.sim_time_s is not None:
        flat["sim_time_s"] = spec.sim_time_s
    n_inst = n_obj = 0
    if spec.instrument_count is not None:
        n_inst = int(rng.integers(spec.instrument_count[0], spec.instrument_count[1] + 1))
    if spec.object_count is not None:
        n_obj = int(rng.integers(spec.object_count[0], spec.object_count[1] + 1))
    if spec.instrument_count is not None and spec.half_angle_deg is not None:
        flat["instruments.names"] = [f"instrument_{k}" for k in range(n_inst)]
        for k in range(n_inst):
            flat[f"instruments.instrument_{k}.boresight_body"] = _unit(rng)
            flat[f"instruments.instrument_{k}.half_angle_deg"] = _uniform(
                rng, spec.half_angle_deg.lo, spec.half_angle_deg.hi
            )
    if spec.object_count is not None:
        flat["bright_objects.names"] = [f"object_{k}" for k in range(n_obj)]
        for k in range(n_obj):
            flat[f"bright_objects.object_{k}.direction_inertial"] = _unit(rng)
    flat["initial_mrp"] = [float(x) for x in Rotation.random(rng=rng).as_mrp()]
    flat["desired_mrp"] = [float(x) for x in Rotation.random(rng=rng).as_mrp()]
    if spec.inertia_scale is not None:
        j = np.asarray(base["inertia_kgm2"], dtype=float).reshape(3, 3)
        values, axes = np.linalg.eigh(j)
        scale = [_uniform(rng, spec.inertia_scale.lo, spec.inertia_scale.hi) for _ in range(3)]
        scaled = axes @ np.diag(values * np.asarray(scale)) @ axes.T
        flat["inertia_kgm2"] = [float(x) for x in (0.5 * (scaled + scaled.T)).ravel()]
    if spec.initial_rate_std_rad_s > 0.0:
        flat["initial_rate_rad_s"] = [
            float(x) for x in rng.normal(scale=spec.initial_rate_std_rad_s, size=3)
        ]
    if spec.max_torque_nm is not None:
        flat["actuators.max_torque_nm"] = [
            _uniform(rng, spec.max_torque_nm.lo, spec.max_torque_nm.hi) for _ in range(3)
        ]
    if spec.max_rate_rad_s is not None:
        flat["actuators.max_rate_rad_s"] = _uniform(
            rng, spec.max_rate_rad_s.lo, spec.max_rate_rad_s.hi
        )
    if spec.keep_in_count is not None and spec.keep_in_max_angle_deg is not None:
        n_keep = int(rng.integers(spec.keep_in_count[0], spec.keep_in_count[1] + 1))
        if n_keep:  # none: no keep_in key (a ROS 2 parameters file has no empty list)
            flat["keep_in.names"] = [f"keep_in_{k}" for k in range(n_keep)]
        for k in range(n_keep):
            flat[f"keep_in.keep_in_{k}.axis_body"] = _unit(rng)
            flat[f"keep_in.keep_in_{k}.direction_inertial"] = _unit(rng)
            flat[f"keep_in.keep_in_{k}.max_angle_deg"] = _uniform(
                rng, spec.keep_in_max_angle_deg.lo, spec.keep_in_max_angle_deg.hi
            )
    if spec.sky_epoch_s is not None:
        lo, hi = spec.sky_epoch_s
        flat["epoch_utc"] = utc_text(int(rng.integers(lo, hi + 1)) if hi > lo else lo)
    if spec.sky_raan_deg is not None:
        flat["orbit.raan_deg"] = _uniform(rng, spec.sky_raan_deg.lo, spec.sky_raan_deg.hi)
    if spec.sky_true_anomaly_deg is not None:
        flat["orbit.true_anomaly_deg"] = _uniform(
            rng, spec.sky_true_anomaly_deg.lo, spec.sky_true_anomaly_deg.hi
        )
    if spec.sensors:
        _draw_sensors(spec, base, rng, flat)
    if spec.link:
        _draw_link(spec, rng, flat)
    if spec.wheels:
        _draw_wheels(spec, base, rng, flat)
    if spec.plan_targets:
        _draw_plan(spec, rng, flat)
    return flat


def _draw_plan(spec: CampaignSpec, rng: np.random.Generator, flat: dict[str, Any]) -> None:
    """An observation plan into ``flat`` instead of ``desired_mrp``: ``plan_targets``
    targets uniform over SO(3), each with a dwell uniform in ``plan_dwell_s``."""
    assert spec.plan_dwell_s is not None
    del flat["desired_mrp"]
    names = [f"target_{k}" for k in range(spec.plan_targets)]
    flat["plan.names"] = names
    for name in names:
        flat[f"plan.{name}.desired_mrp"] = [float(x) for x in Rotation.random(rng=rng).as_mrp()]
        flat[f"plan.{name}.dwell_s"] = _uniform(rng, spec.plan_dwell_s.lo, spec.plan_dwell_s.hi)


def _draw_wheels(
    spec: CampaignSpec, base: dict[str, Any], rng: np.random.Generator, flat: dict[str, Any]
) -> None:
    """Step 9 of the module docstring, into ``flat``: the wheels' biases and a failure."""
    names = list(base["wheels.names"])
    if spec.wheel_speed_rpm is not None:
        for name in names:
            flat[f"wheels.{name}.initial_speed_rpm"] = _uniform(
                rng, spec.wheel_speed_rpm.lo, spec.wheel_speed_rpm.hi
            )
    if spec.wheel_failure_share is not None and spec.wheel_fails_at_s is not None:
        fails = float(rng.random()) < spec.wheel_failure_share
        which = int(rng.integers(len(names)))
        when = _uniform(rng, spec.wheel_fails_at_s.lo, spec.wheel_fails_at_s.hi)
        if fails:
            flat[f"wheels.{names[which]}.fails_at_s"] = when


def _draw_link(spec: CampaignSpec, rng: np.random.Generator, flat: dict[str, Any]) -> None:
    """Step 8 of the module docstring, into ``flat``: the run's rehearsal link."""
    flat["link.seed"] = int(rng.integers(0, 2**31 - 1))
    for field, key in (
        ("link_latency_s", "link.state_latency_s"),
        ("link_jitter_s", "link.jitter_s"),
        ("link_drop_rate", "link.drop_rate"),
    ):
        span = getattr(spec, field)
        if span is not None:
            flat[key] = _uniform(rng, span.lo, span.hi)
    if spec.outage_count is not None:
        start, duration = spec.outage_start_s, spec.outage_duration_s
        assert start is not None and duration is not None
        lo, hi = spec.outage_count
        outages: list[float] = []
        for _ in range(int(rng.integers(lo, hi + 1))):
            length = _uniform(rng, duration.lo, duration.hi)
            outages += [_uniform(rng, start.lo, start.hi), max(length, 1e-3)]
        flat["link.outages"] = outages


def _draw_sensors(
    spec: CampaignSpec, base: dict[str, Any], rng: np.random.Generator, flat: dict[str, Any]
) -> None:
    """Step 7 of the module docstring, into ``flat``."""
    flat["sensors.seed"] = int(rng.integers(0, 2**31 - 1))
    if spec.star_tracker_noise_scale is not None:
        f = _uniform(rng, spec.star_tracker_noise_scale.lo, spec.star_tracker_noise_scale.hi)
        noise = base["sensors.star_tracker.noise_arcsec"]
        flat["sensors.star_tracker.noise_arcsec"] = [float(x) * f for x in noise]
    if spec.star_tracker_rate_hz is not None:
        rate = spec.star_tracker_rate_hz
        flat["sensors.star_tracker.rate_hz"] = _uniform(rng, rate.lo, rate.hi)
    if spec.gyro_noise_rad_s is not None:
        noise_range = spec.gyro_noise_rad_s
        flat["sensors.gyro.noise_rad_s"] = _uniform(rng, noise_range.lo, noise_range.hi)
    if spec.gyro_bias_rad_s is not None:
        bias = spec.gyro_bias_rad_s
        flat["sensors.gyro.bias_rad_s"] = [
            _uniform(rng, bias.lo, bias.hi) * (1.0 if rng.random() < 0.5 else -1.0)
            for _ in range(3)
        ]


def _plain(flat: dict[str, Any]) -> bool:
    """Whether the drawn values alone give the exact margins: fixed inertial objects and
    keep-in directions, each instrument avoiding every object by its half-angle."""
    for key in flat:
        parts = key.split(".")
        if parts[0] in GROUPS and len(parts) > 2 and parts[2] in _SKY_KEYS:
            return False
    return all(f"instruments.{n}.half_angle_deg" in flat for n in flat["instruments.names"])


def _end_margin_deg(
    flat: dict[str, Any], scenario: Scenario | None = None, goal_placed: bool = False
) -> float:
    """The smallest margin of the drawn start and goal attitudes over every constraint:
    keep-out (eq. 5, from the limb) and keep-in (``max_angle_deg`` minus the axis' angle
    to its direction).

    A plain draw (:func:`_plain`) is measured on the drawn values, before the loader;
    any other on ``scenario`` (the loaded draw): the start at ``t = 0``, the goal at every
    :data:`GOAL_SAMPLE_S` over ``[0, sim_time_s]`` (the module docstring says why).
    ``goal_placed`` (``goal_near_keep_out``): the start's only, on ``scenario``."""
    if not _plain(flat) or goal_placed:
        if scenario is None:
            raise ValueError(
                "a draw with ephemeris or moving objects, or per-object exclusions, is "
                "measured on its loaded scenario"
            )
        return _sky_end_margin_deg(scenario, goal_placed)
    inst = flat["instruments.names"]
    objs = flat["bright_objects.names"]
    s = np.array([flat[f"instruments.{n}.boresight_body"] for n in inst], dtype=float)
    beta = np.array([flat[f"instruments.{n}.half_angle_deg"] for n in inst], dtype=float)
    c = np.array([flat[f"bright_objects.{n}.direction_inertial"] for n in objs], dtype=float)
    goals = [flat[f"plan.{n}.desired_mrp"] for n in flat.get("plan.names", ())]
    ends = np.array([flat["initial_mrp"], *(goals or [flat["desired_mrp"]])], dtype=float)
    rotation = Rotation.from_mrp(ends)  # active: C_NB = C_BN^T
    c_bn = np.linalg.inv(rotation.as_matrix())
    smallest = float(margins_deg_from_dcm(c_bn, s, beta, c).min())
    for n in flat.get("keep_in.names", ()):
        a = np.asarray(flat[f"keep_in.{n}.axis_body"], dtype=float)
        d = np.asarray(flat[f"keep_in.{n}.direction_inertial"], dtype=float)
        cos = rotation.apply(a / np.linalg.norm(a)) @ (d / np.linalg.norm(d))
        angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        smallest = min(smallest, float(flat[f"keep_in.{n}.max_angle_deg"] - angle.max()))
    return smallest


def _place_goal(
    spec: CampaignSpec, i: int, flat: dict[str, Any], sc: Scenario, u: float, offset_deg: float
) -> Scenario | None:
    """``goal_near_keep_out``: the goal of ``flat`` turned to ``offset_deg`` outside the
    keep-out pair ``u`` picks, loaded again; None when another constraint is nearer
    than the offset at ``t = 0`` (or the boresight is along the object)."""
    pairs = keep_out_pairs(sc.sky)
    if not pairs:
        raise ValueError(f"{spec.name}: goal_near_keep_out needs a keep-out pair")
    try:
        goal = goal_at_margin(sc.sky, sc.desired_mrp, int(u * pairs), offset_deg)
    except ValueError:
        return None
    if float(sc.sky.constraint_margins_deg(0.0, goal).min()) < offset_deg - 1e-6:
        return None
    flat["desired_mrp"] = [float(x) for x in goal]
    return parse_scenario(as_read_back(flat), f"<{spec.name} run {i}>")


def _sky_end_margin_deg(sc: Scenario, goal_placed: bool = False) -> float:
    """The start's margin at ``t = 0`` and the goal's smallest over the run, on the sky
    (a goal placed near a keep-out: the start's only)."""
    t = np.append(np.arange(0.0, sc.sim_time_s, GOAL_SAMPLE_S), sc.sim_time_s)
    start = sc.sky.constraint_margins_deg(0.0, np.asarray(sc.initial_mrp, dtype=float))
    smallest = float(start.min())
    if goal_placed:
        return smallest
    for sigma in [p.desired_mrp for p in sc.plan] or [sc.desired_mrp]:
        goal = np.broadcast_to(np.asarray(sigma, dtype=float), (len(t), 3))
        smallest = min(smallest, float(sc.sky.constraint_margins_deg(t, goal).min()))
    return smallest


def scenario_text(flat: dict[str, Any]) -> str:
    """A complete scenario file for drawn parameters."""
    return to_yaml(flat)


def as_read_back(flat: dict[str, Any]) -> dict[str, Any]:
    """The dotted values that :func:`scenario_text` read back holds: lists for tuples
    (YAML has no tuple; every other drawn or base value, a float, an integer, a string, a
    boolean or a list of them, reads back as itself)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in flat.items()}


def draw_run(spec: CampaignSpec, base: dict[str, Any], i: int, variant: str | None = None) -> Draw:
    """The scenario of run ``i`` (every variant of the run flies this one), flown by
    ``variant`` (``planner.variant``; None: the base scenario's)."""
    rng = np.random.default_rng([spec.seed, i])
    refused = close = 0
    for _ in range(MAX_REDRAWS):
        flat = _candidate(spec, base, i, rng)
        if variant is not None:
            flat["planner.variant"] = variant
        near = spec.goal_near_keep_out_deg
        placed = None if near is None else (float(rng.random()), _uniform(rng, near.lo, near.hi))
        plain = _plain(flat) and placed is None
        if plain and _end_margin_deg(flat) < spec.min_end_margin_deg:
            close += 1  # cheap check first: the loader would refuse one inside a cone
            continue
        sc: Scenario | None
        try:
            sc = parse_scenario(as_read_back(flat), f"<{spec.name} run {i}>")
            if placed is not None:
                sc = _place_goal(spec, i, flat, sc, *placed)
        except ScenarioError:
            refused += 1
            continue
        if sc is None or (
            not plain and _end_margin_deg(flat, sc, placed is not None) < spec.min_end_margin_deg
        ):
            close += 1  # a moving sky: measured on the loaded scenario's
            continue
        return Draw(i, flat, sc, refused, close)
    raise RuntimeError(
        f"run {i}: no valid scenario in {MAX_REDRAWS} draws ({refused} refused by the "
        f"loader, {close} within {spec.min_end_margin_deg} deg of a constraint): "
        "the dispersions cannot be met"
    )
