"""The FEPF step in both forms: the compiled ``_kernels.FepfCore`` (kernels/fepf.pxi) and
the Python reference (``FepfPlanner.propose_reference`` / ``hold_rate_reference`` /
``advance_reference``), each on the planner's state record (``FepfState``, compiled or
Python). :class:`FepfChecks` runs once with each form (CPython's ``heapq`` / ``_heapq``
way); the module's own tests compare the forms to the bit: a compiled planner, the
reference stepping the same compiled record (the two forms taking turns) and a planner
made wholly of the references, on random planner states of the paper's and our variants
(property tests), and along whole guided slews."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core import kernels
from attitude_core.assembly.guidance import guidance_from_scenario, planner_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.fepf import FepfPlanner, PlannerOutput
from attitude_core.fsw.guidance.fepf_state import FepfState
from attitude_core.models.mrp import omega_from_mrp_rate_single
from tests.support import MODE_SETTINGS, ROOT, KernelModeTests
from tests.support import exact_bits as _bits

needs_compiled = pytest.mark.skipif(
    kernels.built() is None, reason="the compiled kernels are not built (run tools/bootstrap)"
)

NAMES = ("case1", "case2", "case1_paper", "case2_paper", "keep_in", "two_instruments")
MEMOS = ("margin_at", "margin", "arc_key", "arc")
STATE = tuple(f for f in FepfState.__slots__ if f not in MEMOS)
"""The record's fields a step decides (its memos of pure functions aside)."""


def _output_bits(out: PlannerOutput) -> tuple[Any, ...]:
    return tuple(
        _bits(getattr(out, f))
        for f in ("sigma_t", "sigma_t_dot", "omega_t", "status", "m_a", "m_r")
    ) + (_bits(float(out.obstacle_distance_mrp)),)


def _state_bits(planner: FepfPlanner) -> list[Any]:
    return [_bits(getattr(planner.state, k)) for k in STATE]


@functools.cache
def _planner(mode: str, name: str, watchdog: bool) -> FepfPlanner:
    """One planner per scenario and watchdog, made with the ``mode`` kernels (its state
    is set before each use)."""
    with kernels.selected(mode):
        planner = planner_from_scenario(
            load_scenario(ROOT / f"scenarios/{name}.yaml"), watchdog=watchdog
        )
    assert (planner.compiled_core is not None) == (mode == "compiled")
    return planner


KEYS = [(n, w) for n in NAMES for w in (False, True)]
unit = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(unit, unit, unit)
small = st.tuples(*[st.floats(-0.05, 0.05, allow_nan=False)] * 3)
STATES = (
    st.sampled_from(KEYS),
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


def _state(sigma, goal, rate, omega, status, final, evade, beyond, goal_mix) -> dict[str, Any]:
    """A random planner state: a target, a goal near it or anywhere, a held rate."""
    if goal_mix > 0.0:  # a goal near the target: capture, landing and the terminal rule
        goal = tuple(s + goal_mix * g for s, g in zip(sigma, goal, strict=True))
    return {
        "sigma_t": tuple(x / max(1.0, math.hypot(*sigma)) for x in sigma),
        "goal": tuple(x / max(1.0, math.hypot(*goal)) for x in goal),
        "rate": rate,
        "omega_held": omega,
        "status": status,
        "final_goal": final,
        "evade": evade,
        "beyond_mrp": beyond,
        "last_obstacle_distance": math.nan,
    }


def _set(planner: FepfPlanner, state: dict[str, Any]) -> None:
    """The planner restarted (``reset``: nothing left of a previous example) and then
    put in ``state``."""
    planner.reset(state["sigma_t"])
    st_ = planner.state
    st_.goal_in_sight = False
    for key, value in state.items():
        setattr(st_, key, value)


def _fly(planner: FepfPlanner, dt: float, dt_move: float, shaped, reference: bool) -> list[Any]:
    """Propose, a guidance's shaped rate (hold_rate) and the move (advance), then the
    checked step taken as is: the outputs and the record after each (``reference``: the
    Python step's methods, whatever the planner's form)."""
    propose = planner.propose_reference if reference else planner.propose
    hold_rate = planner.hold_rate_reference if reference else planner.hold_rate
    advance = planner.advance_reference if reference else planner.advance
    out = propose(dt, dt)
    snap = [_output_bits(out), *_state_bits(planner)]
    snap.append(
        _bits(hold_rate(tuple(a + b for a, b in zip(out.sigma_t_dot, shaped, strict=True)), dt))
    )
    advance(dt_move)
    snap += _state_bits(planner)
    advance(dt)  # the checked step taken as is
    snap += _state_bits(planner)
    return snap


def _shadow_switched(sigma) -> tuple[float, ...]:
    """Where the planner's move puts a target at ``sigma``: its shadow set beyond the
    unit ball (eq. 2), in the planner's operations."""
    s2 = sigma[0] ** 2 + sigma[1] ** 2 + sigma[2] ** 2
    return tuple(-x / s2 for x in sigma) if s2 > 1.0 else tuple(sigma)


class FepfChecks(KernelModeTests):
    """What each form of the FEPF step must do."""

    @settings(max_examples=500, **MODE_SETTINGS)
    @given(*STATES)
    def test_a_step_from_a_random_state_keeps_its_invariants(
        self,
        key,
        sigma,
        goal,
        rate,
        omega,
        status,
        final,
        evade,
        beyond,
        dt,
        dt_move,
        shaped,
        goal_mix,
    ):
        """The output is the target held or moved from, with its eq. 12 body rate and the
        planner's status; the rate held is the output's; the move keeps the target in
        the unit ball (eq. 2) and takes a checked step as is."""
        planner = _planner(self.mode, *key)
        _set(planner, _state(sigma, goal, rate, omega, status, final, evade, beyond, goal_mix))
        before = planner.sigma_t
        out = planner.propose(dt, dt)
        st_ = planner.state
        assert out.status == st_.status
        assert out.sigma_t.tobytes() == np.array(st_.sigma_t).tobytes()
        assert st_.sigma_t in (before, st_.goal)  # held or landed on the goal
        assert out.omega_t.tobytes() == omega_from_mrp_rate_single(st_.sigma_t, st_.rate).tobytes()
        assert tuple(out.sigma_t_dot.tolist()) == st_.rate
        assert st_.checked is None or st_.checked == (st_.rate, dt)
        held = planner.hold_rate(
            tuple(a + b for a, b in zip(out.sigma_t_dot, shaped, strict=True)), dt
        )
        assert held == st_.rate and st_.checked == (held, dt)
        planner.advance(dt_move)
        assert math.hypot(*planner.sigma_t) <= 1.0 + 1e-12
        checked = st_.checked
        if st_.status == PlannerStatus.TRACKING and checked and checked[0] == st_.rate:
            start, kept = planner.sigma_t, st_.rate
            planner.advance(dt)  # the checked step: taken as is (or landed on the goal)
            end = tuple(s + r * dt for s, r in zip(start, kept, strict=True))
            assert planner.sigma_t in (_shadow_switched(end), _shadow_switched(st_.goal))

    @pytest.mark.parametrize("name", NAMES)
    def test_a_guided_slew_is_flown(self, name):
        """A guidance over this form's planner, the body halfway to its target each step:
        the target moves towards the goal and the slew is flown, not held."""
        sc = load_scenario(ROOT / f"scenarios/{name}.yaml")
        g = guidance_from_scenario(sc)
        assert (g.planner.compiled_core is not None) == (self.mode == "compiled")
        sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
        tracking = 0
        for k in range(int(sc.sim_time_s / sc.dt_s)):
            out = g.update(k * sc.dt_s, sigma, omega)
            tracking += out.target.status == PlannerStatus.TRACKING
            sigma = 0.5 * (sigma + out.target.sigma_t)
            omega = np.asarray(out.target.omega_t, dtype=float)
            if out.target.status == PlannerStatus.ARRIVED and g.status == PlannerStatus.ARRIVED:
                break
        assert tracking > 50
        assert g.status == PlannerStatus.ARRIVED


@needs_compiled
class TestCompiledFepf(FepfChecks):
    mode = "compiled"


class TestPythonFepf(FepfChecks):
    mode = "python"


# -- the forms against each other ----------------------------------------------------


@needs_compiled
def test_the_compiled_record_is_the_python_record():
    """The compiled ``FepfState`` has the Python record's fields, with its defaults."""
    compiled, python = kernels.built().FepfState(), FepfState()
    assert {f for f in dir(compiled) if not f.startswith("_")} == set(FepfState.__slots__)
    for f in FepfState.__slots__:
        assert _bits(getattr(compiled, f)) == _bits(getattr(python, f)), f


@needs_compiled
@settings(max_examples=1500, deadline=None)
@given(*STATES)
def test_the_compiled_step_is_the_reference_to_the_bit(
    key, sigma, goal, rate, omega, status, final, evade, beyond, dt, dt_move, shaped, goal_mix
):
    """Propose, a guidance's shaped rate (hold_rate) and the move (advance), from the
    same random state, give the same outputs and leave the same state: the compiled step,
    the Python step on the same compiled record and geometry (the forms taking turns on
    one planner), and a planner made wholly of the Python references."""
    state = _state(sigma, goal, rate, omega, status, final, evade, beyond, goal_mix)
    compiled = _planner("compiled", *key)
    python = _planner("python", *key)
    results = []
    for planner, reference in ((compiled, False), (compiled, True), (python, False)):
        _set(planner, state)
        results.append(_fly(planner, dt, dt_move, shaped, reference))
    assert results[0] == results[1] == results[2]


@needs_compiled
@pytest.mark.parametrize("name", NAMES)
def test_a_guided_slew_is_the_reference_to_the_bit(name):
    """Two guidances fed the same states, one made with the compiled kernels and one with
    the Python references: the same target and planner state at every step of a whole
    slew (the states of a body that lags its target, so the governor, the time scaling
    and the routes all act)."""
    sc = load_scenario(ROOT / f"scenarios/{name}.yaml")
    with kernels.selected("compiled"):
        compiled = guidance_from_scenario(sc)
    with kernels.selected("python"):
        reference = guidance_from_scenario(sc)
    assert reference.planner.compiled_core is None
    sigma, omega = np.array(sc.initial_mrp, dtype=float), np.zeros(3)
    tracking = 0
    for k in range(int(sc.sim_time_s / sc.dt_s)):
        t = k * sc.dt_s
        a = compiled.update(t, sigma, omega)
        b = reference.update(t, sigma, omega)
        assert _output_bits(a.target) == _output_bits(b.target), (name, k)
        assert (a.tracking_error_deg, a.speed_factor) == (b.tracking_error_deg, b.speed_factor)
        assert _state_bits(compiled.planner) == _state_bits(reference.planner), (name, k)
        tracking += a.target.status == PlannerStatus.TRACKING
        # the body: halfway to the target each step, with the target's rate
        sigma = 0.5 * (sigma + a.target.sigma_t)
        omega = np.asarray(a.target.omega_t, dtype=float)
        if a.target.status == PlannerStatus.ARRIVED and compiled.status == PlannerStatus.ARRIVED:
            break
    assert tracking > 50  # the slew was flown, not held
