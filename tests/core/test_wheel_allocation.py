"""Wheel allocation (fsw/control/wheel_allocation.py): the minimum-norm pseudo-inverse
inside the envelope, redistribution when a wheel saturates, a torque outside the
envelope scaled along its direction to the polytope's reach (a linear programme as the
oracle), and wheels taken out or at their speed limit."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from attitude_core.fsw.control.wheel_allocation import allocate, wheel_bounds
from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec
from tests.core.test_wheel_array import pyramid


def reach_lp(array, d, lo, hi) -> float:
    """``max s`` with ``-G u = s d`` in the bounds, written out for linprog here."""
    n = len(array)
    res = linprog(
        np.r_[np.zeros(n), -1.0],
        A_eq=np.hstack([-array.axes, -np.reshape(d, (3, 1))]),
        b_eq=np.zeros(3),
        bounds=list(zip(lo, hi, strict=True)) + [(0.0, None)],
        method="highs",
    )
    return float(res.x[-1])


def check_bounds(u, lo, hi):
    assert np.all(u >= lo - 1e-15) and np.all(u <= hi + 1e-15)


def test_inside_the_envelope_the_allocation_is_the_minimum_norm_one():
    array = pyramid()
    lo, hi = wheel_bounds(array, np.zeros(4), [True] * 4)
    tau = np.array([0.002, -0.001, 0.003])
    a = allocate(array, tau, lo, hi)
    np.testing.assert_allclose(a.motor_torque_nm, -np.linalg.pinv(array.axes) @ tau, atol=1e-15)
    np.testing.assert_allclose(a.achieved_b, tau, atol=1e-15)
    assert not a.saturated


def test_a_saturating_wheel_is_fixed_and_the_others_make_up_the_torque():
    array = pyramid()
    lo, hi = wheel_bounds(array, np.zeros(4), [True] * 4)
    rng = np.random.default_rng(4)
    redistributed = 0
    for _ in range(200):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        tau = 0.97 * array.torque_along(d) * d  # inside, near the rim
        a = allocate(array, tau, lo, hi)
        check_bounds(a.motor_torque_nm, lo, hi)
        np.testing.assert_allclose(a.achieved_b, tau, atol=1e-12)
        assert not a.saturated
        # the plain pseudo-inverse would have passed a wheel's bound
        redistributed += np.any(np.abs(np.linalg.pinv(array.axes) @ tau) > hi)
    assert redistributed > 50


@pytest.mark.parametrize("out", [None, 1])
def test_outside_the_envelope_the_direction_is_kept_at_the_polytopes_reach(out):
    array = pyramid()
    usable = [i != out for i in range(4)]
    lo, hi = wheel_bounds(array, np.zeros(4), usable)
    rng = np.random.default_rng(5)
    for _ in range(100):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        a = allocate(array, 0.5 * d, lo, hi)  # far outside (0.5 N m)
        check_bounds(a.motor_torque_nm, lo, hi)
        assert a.saturated
        np.testing.assert_allclose(a.achieved_b, reach_lp(array, d, lo, hi) * d, atol=1e-12)
        if out is not None:
            assert a.motor_torque_nm[out] == 0.0


def test_a_wheel_at_its_speed_limit_only_slows_down():
    array = pyramid(speeds=(6000 * RPM, 0.0, -6000 * RPM, 0.0))
    lo, hi = wheel_bounds(array, array.initial_speed, [True] * 4)
    assert hi[0] == 0.0 and lo[0] < 0.0 and lo[2] == 0.0 and hi[2] > 0.0
    rng = np.random.default_rng(6)
    for _ in range(100):
        tau = rng.normal(size=3) * 0.004
        a = allocate(array, tau, lo, hi)
        check_bounds(a.motor_torque_nm, lo, hi)
        assert a.motor_torque_nm[0] <= 0.0 and a.motor_torque_nm[2] >= 0.0


axis = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(axis, min_size=3, max_size=6),
    st.lists(st.floats(1e-3, 0.1), min_size=6, max_size=6),
    st.tuples(*[st.floats(-0.3, 0.3)] * 3),
    st.lists(st.booleans(), min_size=6, max_size=6),
)
@example(  # one usable wheel, a torque 3e-9 rad off its axis
    axes=[(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 1.0, 1.0)],
    max_torques=[0.0625, 0.03125, 0.0625, 0.0625, 0.0625, 0.0625],
    tau=(0.0625, 0.0, 2.1168226436805918e-10),
    usable=[False, True, False, False, False, False],
)
def test_any_array_any_torque(axes, max_torques, tau, usable):
    """Bounds always hold; the body torque is the wanted one, or the largest along its
    direction that the usable wheels can make."""
    wheels = tuple(
        WheelSpec(f"w{i}", tuple(np.asarray(v) / np.linalg.norm(v)), max_torques[i], 600.0, 1e-3)
        for i, v in enumerate(axes)
    )
    array = WheelArray(wheels)
    n = len(array)
    lo, hi = wheel_bounds(array, np.zeros(n), usable[:n])
    a = allocate(array, tau, lo, hi)
    check_bounds(a.motor_torque_nm, lo, hi)
    size = float(np.linalg.norm(tau))
    if size == 0.0:
        assert not np.any(a.motor_torque_nm)
        return
    d = np.asarray(tau) / size
    expected = min(size, reach_lp(array, d, lo, hi))
    # to the LP's feasibility tolerance (HiGHS, 1e-7 relative): a direction 1e-9 off a
    # single wheel's axis has a reach of 0 exactly but is within its tolerance of one
    np.testing.assert_allclose(a.achieved_b, expected * d, atol=1e-8)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),
    st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=3),
    st.sampled_from([0.01, 0.1, 0.5]),
)
def test_with_the_step_no_wheel_is_commanded_past_its_speed_limit(fractions, tau, dt):
    array = pyramid()
    speeds = np.asarray(fractions) * array.max_speed
    lo, hi = wheel_bounds(array, speeds, [True] * 4, dt)
    check_bounds(np.zeros(4), lo, hi)  # zero torque is always allowed
    u = allocate(array, np.asarray(tau), lo, hi).motor_torque_nm
    check_bounds(u, lo, hi)
    assert np.all(np.abs(u) <= array.max_torque * (1 + 1e-12))
    after = speeds + u * dt / array.spin_inertia  # the wheels' own spin-up over the step
    assert np.all(np.abs(after) <= array.max_speed * (1 + 1e-9))
    # far from the limit, the step's bound is the motor's own
    far = np.abs(speeds) + array.max_torque * dt / array.spin_inertia < array.max_speed
    free_lo, free_hi = wheel_bounds(array, speeds, [True] * 4)
    assert np.all(hi[far] == free_hi[far]) and np.all(lo[far] == free_lo[far])
