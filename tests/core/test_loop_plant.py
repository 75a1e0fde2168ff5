"""The offline loop's controller and plant (``gnc/loop_plant.py``): the compiled
``_kernels.LoopPlant`` against :class:`LoopPlantReference` to the bit, on random
bodies, gains, bounds, fed states and targets (property tests), and its hold inside a
band about a goal against single steps."""

import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core.gnc import kernels
from attitude_core.gnc.control import PdGains
from attitude_core.gnc.dynamics import RigidBody
from attitude_core.gnc.loop_plant import HOLD_GUARD, LoopPlantReference, loop_plant
from attitude_core.gnc.mrp import angle_between_single, compose

K = kernels.compiled
pytestmark = pytest.mark.skipif(
    K is None and os.environ.get(kernels.ENV) == "python",
    reason="the Python reference was selected (ATTITUDE_KERNELS=python)",
)

unit = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(unit, unit, unit)
rate = st.tuples(*[st.floats(-0.5, 0.5, allow_nan=False)] * 3)


def _inertia(rng: np.random.Generator) -> np.ndarray:
    a, b = np.sort(rng.uniform(1.0, 20.0, 2))
    moments = np.array([a, b, rng.uniform(b - a + 0.5, a + b - 0.1)])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q @ np.diag(moments) @ q.T


def _records(n: int, body: RigidBody) -> list[np.ndarray]:
    """The five ``(n + 1, 3)`` arrays of a record of ``n`` steps, row 0 the body's."""
    arrays = [np.full((n + 1, 3), np.nan) for _ in range(5)]
    arrays[0][0], arrays[1][0] = body.sigma_bn, body.omega_b
    return arrays


def _fly(plant, arrays, feeds, targets) -> None:
    sigma, omega = arrays[0], arrays[1]
    for k, ((ds, dw), (sr, wr)) in enumerate(zip(feeds, targets, strict=True)):
        # the state the loop is fed: the body's (no sensors) or an estimate near it
        sigma_m = sigma[k] + np.asarray(ds)
        omega_m = omega[k] + np.asarray(dw)
        plant.step(k, sigma_m, omega_m, sr, wr)


@settings(max_examples=200, deadline=None)
@given(
    vec,
    rate,
    st.integers(0, 2**32 - 1),
    st.sampled_from([None, (0.05, 0.02, 0.08), (1e-4, 1e-4, 1e-4), (1e-9, 1.0, 1.0)]),
    st.lists(st.tuples(st.tuples(*[st.floats(-0.01, 0.01)] * 3), rate), min_size=1, max_size=6),
    st.lists(st.tuples(vec, rate), min_size=6, max_size=6),
    st.sampled_from([0.1, 0.01, 0.5]),
)
def test_the_compiled_plant_is_the_reference_to_the_bit(
    sigma, omega, seed, bound, feeds, targets, dt
):
    rng = np.random.default_rng(seed)
    j = _inertia(rng)
    gains = PdGains(rng.uniform(0.5, 8.0) * j, rng.uniform(0.5, 8.0) * j)
    n = len(feeds) - 1  # rows 0..n: n propagations
    targets = targets[: n + 1]
    body_a, body_b = RigidBody(j, sigma, omega), RigidBody(j, sigma, omega)
    a, b = _records(n, body_a), _records(n, body_b)
    assert K is not None
    compiled = loop_plant(gains, bound, body_a, dt, *a)
    assert not isinstance(compiled, LoopPlantReference)
    _fly(compiled, a, feeds, targets)
    _fly(LoopPlantReference(gains, bound, body_b, dt, *b), b, feeds, targets)
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()  # signed zeros and NaN included
    torque = a[2]
    if bound is not None:  # the plant's bound holds on every row
        assert np.all(np.abs(torque) <= np.asarray(bound))
    assert np.all(np.linalg.norm(a[0], axis=1) <= 1.0)  # the shadow switch, eq. 2
    assert np.array_equal(a[3], np.asarray([t[0] for t in targets]))


def test_the_last_row_is_recorded_and_not_propagated():
    """Row n gets its torque and target; the body is not stepped past the record."""
    j = np.diag([10.0, 12.0, 8.0])
    body = RigidBody(j, (0.1, -0.2, 0.05), (0.01, 0.0, -0.02))
    arrays = _records(2, body)
    plant = loop_plant(PdGains.from_inertia(j), None, body, 0.1, *arrays)
    for k in range(3):
        plant.step(k, arrays[0][k], arrays[1][k], (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert np.all(np.isfinite(arrays[2])) and np.all(np.isfinite(arrays[0]))
    ref = RigidBody(j, (0.1, -0.2, 0.05), (0.01, 0.0, -0.02))
    for k in range(2):
        ref.step(arrays[2][k], 0.1)
        assert np.array_equal(ref.sigma_bn, arrays[0][k + 1])
        assert np.array_equal(ref.omega_b, arrays[1][k + 1])
    # a rest-to-rest pull towards the origin: the torque opposes the attitude error
    assert float(np.dot(arrays[2][0], (0.1, -0.2, 0.05))) < 0.0


def _band_values(sigma: np.ndarray, omega: np.ndarray, goal) -> tuple[float, float]:
    """The guidance's own attitude error (deg) and rate (rad/s) of a record row."""
    return math.degrees(angle_between_single(sigma, goal)), math.hypot(*omega)


@settings(max_examples=150, deadline=None)
@given(
    vec,
    st.integers(0, 2**32 - 1),
    st.sampled_from([None, (0.05, 0.02, 0.08), (1e-3, 1e-3, 1e-3)]),
    st.floats(0.05, 8.0),
    st.floats(1e-4, 0.05),
    st.sampled_from([0.1, 0.5]),
)
def test_a_hold_steps_while_inside_the_band_as_steps_one_at_a_time(
    goal, seed, bound, band_deg, band_rate, dt
):
    """The compiled hold and the reference's stop at the same step, with the same
    record as single steps fed the body's own state and the held target; every row
    stepped is inside the band, the row it stops at is not (or is the end)."""
    rng = np.random.default_rng(seed)
    j = _inertia(rng)
    gains = PdGains(rng.uniform(0.5, 8.0) * j, rng.uniform(0.5, 8.0) * j)
    # a start near the goal, turning: it may leave the band, settle, or never enter it
    kick = rng.normal(size=3) * np.radians(rng.uniform(0.0, 2.0 * band_deg)) / 4.0
    sigma0 = compose(kick, goal)
    omega0 = rng.normal(size=3) * rng.uniform(0.0, 2.0 * band_rate) / math.sqrt(3.0)
    n = 60
    target_sigma, target_omega = np.asarray(goal, dtype=float), np.zeros(3)
    runs = []
    for compiled in (True, False):
        body = RigidBody(j, sigma0, omega0)
        arrays = _records(n, body)
        plant = (
            loop_plant(gains, bound, body, dt, *arrays)
            if compiled
            else LoopPlantReference(gains, bound, body, dt, *arrays)
        )
        stop = plant.hold(0, n + 1, goal, target_sigma, target_omega, band_deg, band_rate)
        runs.append((stop, arrays))
    (stop, a), (stop_ref, b) = runs
    assert stop == stop_ref
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()
    for k in range(stop):
        e, r = _band_values(a[0][k], a[1][k], goal)
        assert e <= band_deg and r <= band_rate
    if stop <= n:
        e, r = _band_values(a[0][stop], a[1][stop], goal)
        assert e > band_deg * (1.0 - HOLD_GUARD) or r > band_rate * (1.0 - HOLD_GUARD)
        assert np.all(np.isnan(a[2][stop:]))  # nothing written past the stop
    # the same rows, a step at a time
    body = RigidBody(j, sigma0, omega0)
    c = _records(n, body)
    single = LoopPlantReference(gains, bound, body, dt, *c)
    for k in range(stop):
        single.step(k, c[0][k], c[1][k], target_sigma, target_omega)
    for x, y in zip(a, c, strict=True):
        assert x.tobytes() == y.tobytes()
