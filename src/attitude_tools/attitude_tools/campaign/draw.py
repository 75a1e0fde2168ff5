"""One dispersed scenario per run index: run ``i`` depends only on ``(seed, i)``.

The random stream of run ``i`` is ``numpy.random.default_rng([seed, i])``, so a run
draws the same scenario whatever the worker, the partitioning or the order. Every draw
goes through the one scenario loader (``loads_scenario``); a draw whose start or goal
lies within ``min_end_margin_deg`` of a cone (checked first, on the drawn values), or
that the loader refuses, is counted and redrawn.
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
    flat = {k: v for k, v in base.items() if not k.startswith(("instruments.", "bright_objects."))}
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
    return flat


def _end_margin_deg(flat: dict[str, Any]) -> float:
    """The smallest keep-out margin (eq. 5) of the drawn start and goal attitudes."""
    inst = flat["instruments.names"]
    objs = flat["bright_objects.names"]
    s = np.array([flat[f"instruments.{n}.boresight_body"] for n in inst], dtype=float)
    beta = np.array([flat[f"instruments.{n}.half_angle_deg"] for n in inst], dtype=float)
    c = np.array([flat[f"bright_objects.{n}.direction_inertial"] for n in objs], dtype=float)
    ends = np.array([flat["initial_mrp"], flat["desired_mrp"]], dtype=float)
    c_bn = np.linalg.inv(Rotation.from_mrp(ends).as_matrix())  # C_BN = (C_NB)^T
    return float(margins_deg_from_dcm(c_bn, s, beta, c).min())


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
        f"loader, {close} within {spec.min_end_margin_deg} deg of a cone): "
        "the dispersions cannot be met"
    )
