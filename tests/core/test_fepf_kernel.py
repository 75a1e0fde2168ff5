"""The compiled FEPF step (``_kernels.FepfCore``, gnc/_fepf_kernel.pxi) against the
Python reference (``FepfPlanner.propose_reference`` / ``hold_rate_reference`` /
``advance_reference``) to the bit: on random planner states of the paper's and our
variants (property tests), and along whole guided slews."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core.config.scenario import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.gnc import kernels
from attitude_core.gnc.fepf import FepfPlanner
from attitude_core.gnc.guidance import Guidance
from tests.support import ROOT
from tests.support import exact_bits as _bits

pytestmark = pytest.mark.skipif(
    kernels.compiled is None and os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
)

NAMES = ("case1", "case2", "case1_paper", "case2_paper", "keep_in", "two_instruments")
STATE = (
    "sigma_t",
    "_rate",
    "_omega_held",
    "status",
    "_d_goal",
    "_raw_speed",
    "last_obstacle_distance",
    "last_obstacle_direction",
    "goal_in_sight",
    "wanted_omega",
    "_best_goal_distance",
    "_since_progress",
)


def _output_bits(out: Any) -> tuple[Any, ...]:
    return tuple(
        _bits(getattr(out, f))
        for f in ("sigma_t", "sigma_t_dot", "omega_t", "status", "m_a", "m_r")
    ) + (_bits(float(out.obstacle_distance_mrp)),)


def _pair(name: str, watchdog: bool) -> tuple[FepfPlanner, FepfPlanner]:
    sc = load_scenario(ROOT / f"scenarios/{name}.yaml")
    compiled = FepfPlanner.from_scenario(sc, watchdog=watchdog)
    reference = FepfPlanner.from_scenario(sc, watchdog=watchdog)
    reference._core = None
    assert compiled._core is not None
    return compiled, reference


PAIRS = {(n, w): _pair(n, w) for n in NAMES for w in (False, True)}

unit = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(unit, unit, unit)
small = st.tuples(*[st.floats(-0.05, 0.05, allow_nan=False)] * 3)


def _set(planner: FepfPlanner, state: dict[str, Any]) -> None:
    for key, value in state.items():
        setattr(planner, key, value)
    planner._margin_at = planner._arc_key = planner._checked = None


@settings(max_examples=1500, deadline=None)
@given(
    st.sampled_from(sorted(PAIRS)),
    vec,
    vec,
    small,
    small,
    st.sampled_from([PlannerStatus.TRACKING] * 4 + [PlannerStatus.ARRIVED, PlannerStatus.STUCK]),
    st.booleans(),
    st.booleans(),
    st.floats(0.0, 0.5),
    st.sampled_from([0.1, 0.05, 0.2, 1e-3]),
    st.sampled_from([0.1, 0.3, 0.0, -0.1]),
    small,
    st.sampled_from([0.0, 1e-3, 1e-2, 0.03, 0.1]),
)
def test_the_compiled_step_is_the_reference_to_the_bit(
    key, sigma, goal, rate, omega, status, final, evade, beyond, dt, dt_move, shaped, goal_mix
):
    """Propose, a guidance's shaped rate (hold_rate) and the move (advance), from the
    same random state, give the same outputs and leave the same state."""
    pair = PAIRS[key]
    if goal_mix > 0.0:  # a goal near the target: capture, landing and the terminal rule
        goal = tuple(s + goal_mix * g for s, g in zip(sigma, goal, strict=True))
    state = {
        "sigma_t": tuple(x / max(1.0, math.hypot(*sigma)) for x in sigma),
        "goal": tuple(x / max(1.0, math.hypot(*goal)) for x in goal),
        "_rate": rate,
        "_omega_held": omega,
        "status": status,
        "final_goal": final,
        "evade": evade,
        "_beyond_mrp": beyond,
        "last_obstacle_distance": math.nan,
    }
    results = []
    for planner in pair:
        _set(planner, state)
        out = planner.propose(dt, dt)
        snap = [_output_bits(out), *(_bits(getattr(planner, k)) for k in STATE)]
        held = planner.hold_rate(
            tuple(a + b for a, b in zip(out.sigma_t_dot, shaped, strict=True)), dt
        )
        snap.append(_bits(held))
        planner.advance(dt_move)
        snap += [_bits(getattr(planner, k)) for k in STATE]
        planner.advance(dt)  # the checked step taken as is
        snap += [_bits(getattr(planner, k)) for k in STATE]
        results.append(snap)
    assert results[0] == results[1]


@pytest.mark.parametrize("name", NAMES)
def test_a_guided_slew_is_the_reference_to_the_bit(name):
    """Two guidances fed the same states, one planner compiled and one the reference:
    the same target and state at every step of a whole slew (the states of a body that
    lags its target, so the governor, the time scaling and the routes all act)."""
    sc = load_scenario(ROOT / f"scenarios/{name}.yaml")
    compiled, reference = Guidance.from_scenario(sc), Guidance.from_scenario(sc)
    reference.planner._core = None
    sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
    tracking = 0
    for k in range(int(sc.sim_time_s / sc.dt_s)):
        t = k * sc.dt_s
        a = compiled.update(t, sigma, omega)
        b = reference.update(t, sigma, omega)
        assert _output_bits(a.target) == _output_bits(b.target), (name, k)
        assert (a.tracking_error_deg, a.speed_factor) == (b.tracking_error_deg, b.speed_factor)
        for key in STATE:
            assert _bits(getattr(compiled.planner, key)) == _bits(getattr(reference.planner, key))
        tracking += a.target.status == PlannerStatus.TRACKING
        # the body: halfway to the target each step, with the target's rate
        sigma = 0.5 * (sigma + a.target.sigma_t)
        omega = np.asarray(a.target.omega_t, dtype=float)
        if a.target.status == PlannerStatus.ARRIVED and compiled.status == PlannerStatus.ARRIVED:
            break
    assert tracking > 50  # the slew was flown, not held
