"""Plausibility bounds (:mod:`attitude_core.runtime.plausibility`)."""

from __future__ import annotations

import math

from support import ROOT

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.runtime.plausibility import (
    DEFAULT_MAX_TORQUE_NM,
    MAX_RATE_RAD_S,
    implausible_mrp,
    implausible_rate,
    implausible_torque,
    torque_bound_nm,
)


def test_torque_bound_is_the_scenarios_limit_when_set_else_the_documented_one():
    assert (
        torque_bound_nm(load_scenario(ROOT / "scenarios/case1.yaml"))
        == (DEFAULT_MAX_TORQUE_NM,) * 3
    )
    wheels = load_scenario(ROOT / "scenarios/case1_wheels.yaml")
    limit = wheels.actuators.max_torque_nm
    assert limit is not None
    bound = torque_bound_nm(wheels)
    assert all(
        b >= v and math.isclose(b, v, rel_tol=1e-8) for b, v in zip(bound, limit, strict=True)
    )
    assert implausible_torque(list(limit), bound) is None
    over = [limit[0] * 1.001, 0.0, 0.0]
    assert "about body axis x exceeds the plausible bound" in implausible_torque(over, bound)


def test_non_finite_and_huge_values_are_named():
    bound = (1.0, 1.0, 1.0)
    assert "non-finite" in implausible_torque([0.0, math.nan, 0.0], bound)
    assert "exceeds" in implausible_torque([0.0, 0.0, -1e300], bound)
    assert implausible_rate([0.1, 0.0, 0.0]) is None
    assert "exceeds" in implausible_rate([MAX_RATE_RAD_S, 0.1, 0.0])
    assert "non-finite" in implausible_rate([math.inf, 0.0, 0.0])
    assert implausible_mrp([0.6, 0.0, 0.8]) is None  # on the unit sphere: the shadow switch
    assert "norm" in implausible_mrp([0.6, 0.0, 0.81], "target MRP")
