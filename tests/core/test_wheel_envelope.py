"""The wheel envelope (fsw/guidance/wheel_envelope.py): the momentum rate limit against
each wheel's room on an orthogonal array, the envelope's cap as the smallest over the
sphere, and rest-to-rest slews flown at the eigenaxis budget (the tightest the model
allows, the stored momentum turning) by the allocation on the wheel plant, every wheel
within its limits."""

import math

import numpy as np
import pytest

from attitude_core.fsw.control.wheel_allocation import allocate, wheel_bounds
from attitude_core.fsw.guidance.profile_limits import TORQUE_USE, time_bound_s
from attitude_core.fsw.guidance.wheel_envelope import (
    MOMENTUM_USE,
    momentum_rate_limit,
    sphere_directions,
    wheel_envelope,
)
from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec
from attitude_core.world.wheel_plant import WheelPlant
from tests.core.test_wheel_array import pyramid

J = np.diag([0.15, 0.2, 0.12])  # a 12U's order of inertia


def test_rate_cap_is_the_room_the_wheel_on_the_axis_has_left():
    js, top = 1e-4, 6000 * RPM
    speeds = np.array([200.0, -100.0, 0.0])
    array = WheelArray(tuple(WheelSpec(f"w{i}", tuple(np.eye(3)[i]), 0.002, top, js)
                             for i in range(3)))  # fmt: skip
    rooms = []
    for axis, sign in ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, 1.0)):
        e = sign * np.eye(3)[axis]
        rate = momentum_rate_limit(array, J, e, 0.0, e, speeds, [True] * 3)
        # body takes +h e, the wheel -h: its speed goes down for a positive axis
        room = js * (top + sign * speeds[axis])
        assert rate[0] == pytest.approx(room / J[axis, axis], rel=1e-9)
        rooms.append(room / J[axis, axis])
        env = wheel_envelope(array, J, e, 0.0, speeds, [True] * 3)
        assert env.accel_rad_s2 == pytest.approx(0.002 / J[axis, axis], rel=1e-9)
        # the cap holds about every axis: the sphere's smallest
        everywhere = momentum_rate_limit(
            array, J, e, 0.0, sphere_directions(256), speeds, [True] * 3
        )
        assert env.rate_rad_s <= MOMENTUM_USE * min(everywhere.min(), rate[0]) * (1 + 1e-12)
    # exact, not sampled: the smallest room of the axes above (each a wheel's worst axis)
    assert env.rate_rad_s == pytest.approx(MOMENTUM_USE * min(rooms), rel=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_a_slew_at_the_envelope_keeps_every_wheel_within_its_limits(seed):
    """Bang-coast-bang about a random axis at MOMENTUM_USE of the eigenaxis rate limit
    and TORQUE_USE of the envelope's acceleration, the torques allocated on the wheels
    and flown on the plant."""
    rng = np.random.default_rng(seed)
    speeds0 = rng.uniform(-0.4, 0.4, 4) * 6000 * RPM  # random biases
    array = pyramid(max_torque=0.004, js=2.5e-5, speeds=tuple(speeds0))
    e = rng.normal(size=3)
    e /= np.linalg.norm(e)
    theta = math.radians(120.0)
    env = wheel_envelope(array, J, e, theta, speeds0, [True] * 4)
    budget = MOMENTUM_USE * momentum_rate_limit(array, J, e, theta, e, speeds0, [True] * 4)[0]
    assert 0.0 < env.rate_rad_s <= budget and env.accel_rad_s2 > 0.0
    accel = TORQUE_USE * env.accel_rad_s2  # as the guidance uses it
    t_acc = budget / accel
    t_total = time_bound_s(theta, budget, accel)
    assert t_total == pytest.approx(theta / budget + t_acc)  # momentum binds
    plant = WheelPlant(J, array, np.zeros(3), np.zeros(3))
    dt = 0.01
    peak = 0.0
    for k in range(int(t_total / dt)):
        t = k * dt
        alpha = accel if t < t_acc else (-accel if t > t_total - t_acc else 0.0)
        # feed-forward torque of the profile plus the gyroscopic term
        h = plant.system_momentum_b()
        tau = J @ (alpha * e) + np.cross(plant.omega_b, h)
        lo, hi = wheel_bounds(array, plant.speeds, [True] * 4)
        a = allocate(array, tau, lo, hi)
        assert not a.saturated
        plant.step(a.motor_torque_nm, t, dt)
        peak = max(peak, float(np.max(np.abs(plant.speeds) / array.max_speed)))
    assert peak <= 1.0
    # the wheels did take the slew's momentum: the peak is near the budget (0.77-0.89
    # of the limit on these four)
    assert peak > 0.7
    assert np.linalg.norm(plant.omega_b) < 0.05 * budget  # at rest again
