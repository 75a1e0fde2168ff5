"""The wheel array (models/wheel_array.py): its checks, momentum identities, and the
reach of its torque polytope against a closed form and a bisection on SciPy's bounded
least squares."""

import math

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec

J = np.diag([10.0, 12.0, 8.0])


def pyramid(max_torque=0.01, js=1e-3, speeds=(0.0, 0.0, 0.0, 0.0)) -> WheelArray:
    tilt = math.radians(54.7356)
    wheels = []
    for i, az in enumerate((45.0, 135.0, 225.0, 315.0)):
        a = math.radians(az)
        axis = (math.cos(a) * math.sin(tilt), math.sin(a) * math.sin(tilt), math.cos(tilt))
        wheels.append(WheelSpec(f"rw{i + 1}", axis, max_torque, 6000 * RPM, js, speeds[i]))
    return WheelArray(tuple(wheels))


def reach_by_bisection(array: WheelArray, d, lo, hi) -> float:
    """The largest ``s`` with ``s d`` reachable: bisection on ``min |-G u - s d|``."""

    free = lo < hi  # a wheel with no room is left out (it applies nothing)
    a_free = -array.axes[:, free]

    def inside(s: float) -> bool:
        fit = lsq_linear(a_free, s * np.asarray(d), bounds=(lo[free], hi[free]), method="bvls")
        return float(np.linalg.norm(a_free @ fit.x - s * np.asarray(d))) < 1e-10

    a, b = 0.0, 1.0
    while inside(b):
        b *= 2.0
    for _ in range(60):
        m = 0.5 * (a + b)
        a, b = (m, b) if inside(m) else (a, m)
    return a


def test_a_valid_pyramid_passes_and_bad_wheels_are_named():
    assert pyramid().problem(J) is None
    good = pyramid().wheels
    cases = {
        "wheels.rw1.max_torque_nm: must be > 0": (
            WheelSpec("rw1", good[0].spin_axis_body, 0.0, 600.0, 1e-3),
        ),
        "wheels.rw1.initial_speed_rpm": (
            WheelSpec("rw1", good[0].spin_axis_body, 0.01, 10.0, 1e-3, 11.0),
        ),
        "wheels.rw1.spin_axis_body: must be a unit vector": (
            WheelSpec("rw1", (1.0, 1.0, 0.0), 0.01, 600.0, 1e-3),
        ),
        "wheels.rw1.fails_at_s": (
            WheelSpec("rw1", good[0].spin_axis_body, 0.01, 600.0, 1e-3, 0.0, -1.0),
        ),
    }
    for words, first in cases.items():
        why = WheelArray(first + good[1:]).problem(J)
        assert why is not None and words in why, why
    planar = tuple(WheelSpec(f"w{i}", (math.cos(a), math.sin(a), 0.0), 0.01, 600.0, 1e-3)
                   for i, a in enumerate((0.0, 1.0, 2.0)))  # fmt: skip
    assert "rank 3" in WheelArray(planar).problem(J)
    assert "names must be unique" in WheelArray(good[:1] + good[:1] + good[2:]).problem(J)
    heavy = pyramid(js=20.0)
    assert "spin inertia" in heavy.problem(J)


def test_system_momentum_is_the_body_and_the_wheels():
    array = pyramid(speeds=(100.0, -50.0, 20.0, 0.0))
    omega = np.array([0.01, -0.02, 0.03])
    h = array.system_momentum_b(J, omega, array.initial_speed)
    by_hand = J @ omega + sum(
        1e-3 * s * np.asarray(w.spin_axis_body)
        for w, s in zip(array.wheels, array.initial_speed, strict=True)
    )
    np.testing.assert_allclose(h, by_hand, atol=1e-15)
    # the hub: J less the wheels' spin inertia along their axes
    hub = array.hub_inertia(J)
    np.testing.assert_allclose(J - hub, 1e-3 * array.axes @ array.axes.T, atol=1e-15)


def test_torque_along_the_axes_of_an_orthogonal_array_is_the_box_radius():
    bounds = (0.01, 0.02, 0.04)
    array = WheelArray(tuple(WheelSpec(f"w{i}", tuple(np.eye(3)[i]), b, 600.0, 1e-3)
                             for i, b in enumerate(bounds)))  # fmt: skip
    rng = np.random.default_rng(0)
    for _ in range(50):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        expected = min(b / abs(x) for b, x in zip(bounds, d, strict=True) if x != 0.0)
        assert array.torque_along(d) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("failed", [None, 0, 3])
def test_torque_along_matches_a_bisection(failed):
    array = pyramid()
    lo, hi = -array.max_torque.copy(), array.max_torque.copy()
    if failed is not None:
        lo[failed] = hi[failed] = 0.0
    rng = np.random.default_rng(1)
    for _ in range(20):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        got = array.torque_along(d, lo, hi)
        assert got == pytest.approx(reach_by_bisection(array, d, lo, hi), rel=1e-7, abs=1e-12)
        assert got > 0.0  # three wheels of a pyramid still span the body
    if failed is None:
        # the pyramid's reach beats the largest cube inside it along every axis
        assert min(array.torque_along(e) for e in np.eye(3)) > 0.01
