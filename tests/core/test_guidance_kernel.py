"""The guidance step in both forms: the compiled ``_kernels.GuidanceCore``
(kernels/guidance.pxi, with route_following.pxi) and ``Guidance.update_reference``, each on
the guidance's state record (``GuidanceState``, compiled or Python) and its planner's.
:class:`GuidanceChecks` runs once with each form (CPython's ``heapq`` / ``_heapq`` way);
the module's own tests compare the forms to the bit: guidances fed the same states (one
made with the compiled kernels, one of them stepped by the Python reference on its
compiled records, the forms taking turns, and one made wholly of the Python references)
give the same target and keep the same state at every step, over whole slews of our
scenarios and random campaign slews (actuator limits, routes, stalls, arrival and its
withdrawal, infeasible slews)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from attitude_core import kernels
from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.config.scenario import Scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.fsw.guidance.guidance_state import GuidanceState
from attitude_core.models.mrp import compose
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import load_spec
from tests.support import ROOT, KernelModeTests
from tests.support import exact_bits as _bits

needs_compiled = pytest.mark.skipif(
    kernels.built() is None, reason="the compiled kernels are not built (run tools/bootstrap)"
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
PLANNER_STATE = ("sigma_t", "rate", "omega_held", "status", "goal", "d_goal")


def _snapshot(g: Guidance, out: Any) -> tuple[Any, ...]:
    target = out.target
    return (
        *(_bits(getattr(target, f)) for f in ("sigma_t", "sigma_t_dot", "omega_t", "status")),
        _bits((target.m_a, target.m_r, float(target.obstacle_distance_mrp))),
        _bits((out.tracking_error_deg, out.goal_error_deg, out.speed_factor, out.derating)),
        *(_bits(getattr(g, k)) for k in GUIDANCE_STATE),
        *(_bits(getattr(g.planner.state, k)) for k in PLANNER_STATE),
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


def _knock(g: Guidance, k: int, sigma: np.ndarray) -> np.ndarray:
    """Every 20th step of an arrival, the body knocked off the goal by a share of the
    tolerance: the arrival kept, or withdrawn (beyond twice the tolerance) and given
    again."""
    share_tol = KNOCKS[(k // 20) % len(KNOCKS)]
    angle = np.radians(share_tol * g.attitude_tol_deg)
    return compose(np.tan(angle / 4.0) * np.array([0.6, 0.0, 0.8]), sigma)


class GuidanceChecks(KernelModeTests):
    """What each form of the guidance step must do."""

    @pytest.mark.parametrize("name", ["case1", "case2", "case1_wheels"])
    def test_a_followed_slew_arrives_and_keeps_its_arrival(self, name):
        """A body that follows its target (halfway each step) arrives; knocked off the
        goal, the arrival is kept or withdrawn and given again."""
        sc = load_scenario(ROOT / f"scenarios/{name}.yaml")
        g = guidance_from_scenario(sc)
        assert (g._core is not None) == (self.mode == "compiled")
        assert isinstance(g.state, GuidanceState) == (self.mode == "python")
        sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
        seen = set()
        knocked = 0
        for k in range(int(sc.sim_time_s / sc.dt_s) + 1):
            out = g.update(k * sc.dt_s, sigma, omega)
            seen.add(g.status)
            assert out.target.status == g.status and g.state.status == g.status
            sigma = sigma + 0.5 * (out.target.sigma_t - sigma)
            omega = 0.5 * np.asarray(out.target.omega_t, dtype=float)
            if g.status == PlannerStatus.ARRIVED and k % 20 == 0:
                sigma = _knock(g, k, sigma)
                knocked += 1
        assert knocked > 5 and PlannerStatus.ARRIVED in seen

    def test_time_going_back_is_refused(self):
        sc = load_scenario(ROOT / "scenarios/case1.yaml")
        g = guidance_from_scenario(sc)
        g.update(1.0, sc.initial_mrp, np.zeros(3))
        with pytest.raises(ValueError, match="before the previous"):
            g.update(0.5, sc.initial_mrp, np.zeros(3))
        with pytest.raises(ValueError, match="repeats the previous"):
            g.update(1.0, sc.initial_mrp, np.zeros(3))
        assert g.t_prev == 1.0


@needs_compiled
class TestCompiledGuidance(GuidanceChecks):
    mode = "compiled"


class TestPythonGuidance(GuidanceChecks):
    mode = "python"


# -- the forms against each other ----------------------------------------------------


@needs_compiled
def test_the_compiled_record_is_the_python_record():
    """The compiled ``GuidanceState`` has the Python record's fields, with its defaults."""
    compiled, python = kernels.built().GuidanceState(), GuidanceState()
    assert {f for f in dir(compiled) if not f.startswith("_")} == set(GuidanceState.__slots__)
    for f in GuidanceState.__slots__:
        assert _bits(getattr(compiled, f)) == _bits(getattr(python, f)), f


@needs_compiled
@pytest.mark.parametrize("body", ["follows", "lags", "stalls"])
@pytest.mark.parametrize("index", range(len(SCENARIOS)))
def test_the_compiled_guidance_is_the_reference_to_the_bit(index, body):
    """A body that follows its target (halfway each step), one that lags it (a tenth
    each step: the governor holds and releases), and one that stays at the start (the
    target stalls, routes are planned again, the slew is declared stuck)."""
    name, sc = SCENARIOS[index]
    with kernels.selected("compiled"):
        compiled, turns = guidance_from_scenario(sc), guidance_from_scenario(sc)
    with kernels.selected("python"):
        reference = guidance_from_scenario(sc)
    assert compiled._core is not None and reference._core is None
    share = {"follows": 0.5, "lags": 0.1, "stalls": 0.0}[body]
    sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
    seen = set()
    for k in range(int(sc.sim_time_s / sc.dt_s) + 1):
        t = k * sc.dt_s
        a = compiled.update(t, sigma, omega)
        b = turns.update_reference(t, sigma, omega)  # the Python step on compiled records
        c = reference.update(t, sigma, omega)
        snap = _snapshot(compiled, a)
        assert snap == _snapshot(turns, b) == _snapshot(reference, c), (name, body, k)
        seen.add(compiled.status)
        sigma = sigma + share * (a.target.sigma_t - sigma)
        omega = share * np.asarray(a.target.omega_t, dtype=float)
        if compiled.status == PlannerStatus.ARRIVED and k % 20 == 0:
            sigma = _knock(compiled, k, sigma)
    assert seen  # every step compared
