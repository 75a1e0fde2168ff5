"""The compiled guidance step (``_kernels.GuidanceCore``, gnc/_guidance_kernel.pxi)
against ``Guidance.update_reference`` to the bit: two guidances fed the same states,
one compiled and one the reference, give the same target and keep the same state at
every step, over whole slews of our scenarios and random campaign slews (actuator
limits, routes, stalls, arrival and its withdrawal, infeasible slews)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest

from attitude_core.config.scenario import Scenario, load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.gnc import kernels
from attitude_core.gnc.guidance import Guidance
from attitude_core.gnc.mrp import compose
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import load_spec
from tests.support import ROOT
from tests.support import exact_bits as _bits

pytestmark = pytest.mark.skipif(
    kernels.compiled is None and os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
)

NAMES = (
    "case1",
    "case2",
    "case1_paper",
    "case2_paper",
    "case1_wheels",
    "case1_small_wheels",
    "two_instruments",
    "keep_in",
    "large_slew",
    "fepf_stall",
    "enclosed_goal",
)
GUIDANCE_STATE = (
    "status",
    "t_prev",
    "derating",
    "replans",
    "_since_progress",
    "_best_body",
    "_best_target",
    "_behind_since",
    "omega_prev",
)
KNOCKS = (0.5, 1.5, 2.03, 2.06, 1.99, 3.0, 2.04)
PLANNER_STATE = ("sigma_t", "_rate", "_omega_held", "status", "goal", "_d_goal")


def _snapshot(g: Guidance, out: Any) -> tuple[Any, ...]:
    target = out.target
    return (
        *(_bits(getattr(target, f)) for f in ("sigma_t", "sigma_t_dot", "omega_t", "status")),
        _bits((target.m_a, target.m_r, float(target.obstacle_distance_mrp))),
        _bits((out.tracking_error_deg, out.goal_error_deg, out.speed_factor, out.derating)),
        *(_bits(getattr(g, k)) for k in GUIDANCE_STATE),
        *(_bits(getattr(g.planner, k)) for k in PLANNER_STATE),
        None if g.follower is None else g.follower.leg,
    )


def _scenarios() -> list[tuple[str, Scenario]]:
    out = [(n, load_scenario(ROOT / f"scenarios/{n}.yaml")) for n in NAMES]
    spec = load_spec(ROOT / "campaigns/random_slews.yaml")
    base = base_parameters(spec)
    out += [
        (f"slew_{i}_{v}", draw_run(spec, base, i, v).scenario)
        for i in range(6)
        for v in ("improved", "paper")
    ]
    return out


SCENARIOS = _scenarios()


@pytest.mark.parametrize("body", ["follows", "lags", "stalls"])
@pytest.mark.parametrize("index", range(len(SCENARIOS)))
def test_the_compiled_guidance_is_the_reference_to_the_bit(index, body):
    """A body that follows its target (halfway each step), one that lags it (a tenth
    each step: the governor holds and releases), and one that stays at the start (the
    target stalls, routes are planned again, the slew is declared stuck)."""
    name, sc = SCENARIOS[index]
    compiled, reference = Guidance.from_scenario(sc), Guidance.from_scenario(sc)
    reference._core = None
    assert compiled._core is not None
    share = {"follows": 0.5, "lags": 0.1, "stalls": 0.0}[body]
    sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
    seen = set()
    knocked = 0
    for k in range(int(sc.sim_time_s / sc.dt_s) + 1):
        t = k * sc.dt_s
        a = compiled.update(t, sigma, omega)
        b = reference.update(t, sigma, omega)
        assert _snapshot(compiled, a) == _snapshot(reference, b), (name, body, k)
        seen.add(compiled.status)
        sigma = sigma + share * (a.target.sigma_t - sigma)
        omega = share * np.asarray(a.target.omega_t, dtype=float)
        if compiled.status == PlannerStatus.ARRIVED and k % 20 == 0:
            # knocked off the goal by a share of the tolerance: the arrival kept, or
            # withdrawn (beyond twice the tolerance) and given again
            share_tol = KNOCKS[(k // 20) % len(KNOCKS)]
            angle = np.radians(share_tol * compiled.attitude_tol_deg)
            sigma = compose(np.tan(angle / 4.0) * np.array([0.6, 0.0, 0.8]), sigma)
            knocked += 1
    assert seen  # every step compared
    if body == "follows" and name in ("case1", "case2", "case1_wheels"):
        assert knocked > 5 and PlannerStatus.ARRIVED in seen


def test_the_compiled_guidance_refuses_time_going_back_as_the_reference_does():
    sc = load_scenario(ROOT / "scenarios/case1.yaml")
    g = Guidance.from_scenario(sc)
    g.update(1.0, sc.initial_mrp, np.zeros(3))
    with pytest.raises(ValueError, match="before the previous"):
        g.update(0.5, sc.initial_mrp, np.zeros(3))
    with pytest.raises(ValueError, match="repeats the previous"):
        g.update(1.0, sc.initial_mrp, np.zeros(3))
    assert g.t_prev == 1.0
