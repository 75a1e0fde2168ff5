"""One dispersed scenario per run index: run ``i`` depends only on ``(seed, i)``.

The random stream of run ``i`` is ``numpy.random.default_rng([seed, i])``, so a run
draws the same scenario whatever the worker, the partitioning or the order. Every draw
goes through the one scenario loader (``loads_scenario``); a draw whose start or goal
lies within ``min_end_margin_deg`` of a constraint boundary (a keep-out cone, or the rim
of a keep-in cone; checked first, on the drawn values), or that the loader refuses, is
counted and redrawn.

The stream is consumed in a fixed order: instrument and object counts, boresights and
half-angles, object directions, start and goal, then the optional dispersions (inertia,
initial rate, actuators) and last the keep-in cones (count, then per cone a body axis,
an inertial direction, both uniform on the unit sphere, and a largest angle uniform in
``max_angle_deg``). An optional dispersion that the SPEC does not give draws nothing, so
adding one to the list never changes the runs of a SPEC without it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from attitude_core.constraints import margins_deg_from_dcm
from attitude_core.scenario import Scenario, ScenarioError, flatten_parameters, loads_scenario
from attitude_core.scenario import scenario_yaml as to_yaml
from attitude_core.scenario_schema import GROUPS
from attitude_core.yamlio import load_strict

from .spec import MAX_REDRAWS, CampaignSpec

__all__ = ["Draw", "base_parameters", "draw_run", "scenario_text"]


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
    # Drawn groups replace the base's; without a keep-in dispersion its cones are kept.
    drawn = [g for g in GROUPS if g != "keep_in" or spec.keep_in_count is not None]
    flat = {k: v for k, v in base.items() if k.split(".", 1)[0] not in drawn}
    flat["scenario_name"] = f"{spec.name}_{i}"
    if spec.sim_time_s is not None:
        flat["sim_time_s"] = spec.sim_time_s
    n_inst = int(rng.integers(spec.instrument_count[0], spec.instrument_count[1] + 1))
    n_obj = int(rng.integers(spec.object_count[0], spec.object_count[1] + 1))
    flat["instruments.names"] = [f"instrument_{k}" for k in range(n_inst)]
    for k in range(n_inst):
        flat[f"instruments.instrument_{k}.boresight_body"] = _unit(rng)
        flat[f"instruments.instrument_{k}.half_angle_deg"] = _uniform(
            rng, spec.half_angle_deg.lo, spec.half_angle_deg.hi
        )
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
    return flat


def _end_margin_deg(flat: dict[str, Any]) -> float:
    """The smallest margin of the drawn start and goal attitudes over every constraint:
    keep-out (eq. 5) and keep-in (``max_angle_deg`` minus the axis' angle to its
    direction)."""
    inst = flat["instruments.names"]
    objs = flat["bright_objects.names"]
    s = np.array([flat[f"instruments.{n}.boresight_body"] for n in inst], dtype=float)
    beta = np.array([flat[f"instruments.{n}.half_angle_deg"] for n in inst], dtype=float)
    c = np.array([flat[f"bright_objects.{n}.direction_inertial"] for n in objs], dtype=float)
    ends = np.array([flat["initial_mrp"], flat["desired_mrp"]], dtype=float)
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


def scenario_text(flat: dict[str, Any]) -> str:
    """A complete scenario file for drawn parameters."""
    return to_yaml(flat)


def draw_run(spec: CampaignSpec, base: dict[str, Any], i: int, variant: str | None = None) -> Draw:
    """The scenario of run ``i`` (every variant of the run flies this one), flown by
    ``variant`` (``planner.variant``; None: the base scenario's)."""
    rng = np.random.default_rng([spec.seed, i])
    refused = close = 0
    for _ in range(MAX_REDRAWS):
        flat = _candidate(spec, base, i, rng)
        if variant is not None:
            flat["planner.variant"] = variant
        if _end_margin_deg(flat) < spec.min_end_margin_deg:
            close += 1  # cheap check first: the loader would refuse one inside a cone
            continue
        try:
            sc = loads_scenario(scenario_text(flat), f"<{spec.name} run {i}>")
        except ScenarioError:
            refused += 1
            continue
        return Draw(i, flat, sc, refused, close)
    raise RuntimeError(
        f"run {i}: no valid scenario in {MAX_REDRAWS} draws ({refused} refused by the "
        f"loader, {close} within {spec.min_end_margin_deg} deg of a constraint): "
        "the dispersions cannot be met"
    )
