"""The offline loop's controller and plant (``loop/loop_plant.py``) in both forms, the
compiled ``_kernels.LoopPlant`` (kernels/loop_plant.pxi) and :class:`LoopPlantReference`:
:class:`PlantChecks` runs once with each form (CPython's ``heapq`` / ``_heapq`` way:
the plant :func:`loop_plant` gives, its bound, its record, its last row, its hold inside
a band about a goal against single steps), and the module's own tests compare the two
to the bit on random bodies, gains, bounds, fed states and targets (property tests)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_core import kernels
from attitude_core.fsw.control.pd import PdGains
from attitude_core.loop.loop_plant import HOLD_GUARD, LoopPlantReference, loop_plant
from attitude_core.models.mrp import angle_between_single, compose
from attitude_core.world.rigid_body import RigidBody
from tests.support import MODE_SETTINGS, KernelModeTests

needs_compiled = pytest.mark.skipif(
    kernels.built() is None, reason="the compiled kernels are not built (run tools/bootstrap)"
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


RANDOM_PLANTS = (
    vec,
    rate,
    st.integers(0, 2**32 - 1),
    st.sampled_from([None, (0.05, 0.02, 0.08), (1e-4, 1e-4, 1e-4), (1e-9, 1.0, 1.0)]),
    st.lists(st.tuples(st.tuples(*[st.floats(-0.01, 0.01)] * 3), rate), min_size=1, max_size=6),
    st.lists(st.tuples(vec, rate), min_size=6, max_size=6),
    st.sampled_from([0.1, 0.01, 0.5]),
)
HOLDS = (
    vec,
    st.integers(0, 2**32 - 1),
    st.sampled_from([None, (0.05, 0.02, 0.08), (1e-3, 1e-3, 1e-3)]),
    st.floats(0.05, 8.0),
    st.floats(1e-4, 0.05),
    st.sampled_from([0.1, 0.5]),
)


def _random_plant(seed: int, dt: float) -> tuple[np.ndarray, PdGains]:
    """A random body and gains the loop can fly at the step ``dt``: ``Kd dt / J <= 1``
    (the explicit sampled loop diverges near ``Kd dt / J = 2``, to numbers a Python
    float cannot square)."""
    rng = np.random.default_rng(seed)
    j = _inertia(rng)
    kd_over_j = rng.uniform(0.5, min(8.0, 1.0 / dt))
    return j, PdGains(rng.uniform(0.5, 8.0) * j, kd_over_j * j)


def _flown(sigma, omega, seed, bound, feeds, targets, dt, reference: bool) -> list[np.ndarray]:
    """The record of a random run of the plant :func:`loop_plant` gives (``reference``:
    :class:`LoopPlantReference` whatever the kernels)."""
    j, gains = _random_plant(seed, dt)
    n = len(feeds) - 1  # rows 0..n: n propagations
    body = RigidBody(j, sigma, omega)
    arrays = _records(n, body)
    plant = (
        LoopPlantReference(gains, bound, body, dt, *arrays)
        if reference
        else loop_plant(gains, bound, body, dt, *arrays)
    )
    _fly(plant, arrays, feeds, targets[: n + 1])
    return arrays


def _held(goal, seed, bound, band_deg, band_rate, dt, reference: bool):
    """A hold of 60 steps from a start near the goal, turning: it may leave the band,
    settle, or never enter it. ``(stop, record, sigma_0, omega_0, gains, j)``."""
    rng = np.random.default_rng(seed)
    j = _inertia(rng)
    gains = PdGains(rng.uniform(0.5, 8.0) * j, rng.uniform(0.5, 8.0) * j)
    kick = rng.normal(size=3) * np.radians(rng.uniform(0.0, 2.0 * band_deg)) / 4.0
    sigma0 = compose(kick, goal)
    omega0 = rng.normal(size=3) * rng.uniform(0.0, 2.0 * band_rate) / math.sqrt(3.0)
    n = 60
    body = RigidBody(j, sigma0, omega0)
    arrays = _records(n, body)
    plant = (
        LoopPlantReference(gains, bound, body, dt, *arrays)
        if reference
        else loop_plant(gains, bound, body, dt, *arrays)
    )
    zero = np.zeros(3)
    stop = plant.hold(0, n + 1, goal, np.asarray(goal, dtype=float), zero, band_deg, band_rate)
    return stop, arrays, sigma0, omega0, gains, j


class PlantChecks(KernelModeTests):
    """What each form of the loop's plant must do."""

    def test_the_plant_is_this_form(self):
        j = np.diag([10.0, 12.0, 8.0])
        body = RigidBody(j, (0.1, -0.2, 0.05), (0.01, 0.0, -0.02))
        plant = loop_plant(PdGains.from_inertia(j), None, body, 0.1, *_records(2, body))
        assert isinstance(plant, LoopPlantReference) == (self.mode == "python")

    @settings(max_examples=200, **MODE_SETTINGS)
    @given(*RANDOM_PLANTS)
    def test_the_plant_keeps_its_bound_and_records_its_targets(
        self, sigma, omega, seed, bound, feeds, targets, dt
    ):
        a = _flown(sigma, omega, seed, bound, feeds, targets, dt, reference=False)
        torque = a[2]
        if bound is not None:  # the plant's bound holds on every row
            assert np.all(np.abs(torque) <= np.asarray(bound))
        assert np.all(np.isfinite(a[0]))
        assert np.all(np.linalg.norm(a[0], axis=1) <= 1.0)  # the shadow switch, eq. 2
        n = len(feeds) - 1
        assert np.array_equal(a[3], np.asarray([t[0] for t in targets[: n + 1]]))
        assert np.array_equal(a[4], np.asarray([t[1] for t in targets[: n + 1]]))

    def test_the_last_row_is_recorded_and_not_propagated(self):
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
            ref.step_reference(arrays[2][k], 0.1)
            assert np.array_equal(ref.sigma_bn, arrays[0][k + 1])
            assert np.array_equal(ref.omega_b, arrays[1][k + 1])
        # a rest-to-rest pull towards the origin: the torque opposes the attitude error
        assert float(np.dot(arrays[2][0], (0.1, -0.2, 0.05))) < 0.0

    @settings(max_examples=150, **MODE_SETTINGS)
    @given(*HOLDS)
    def test_a_hold_steps_while_inside_the_band_as_steps_one_at_a_time(
        self, goal, seed, bound, band_deg, band_rate, dt
    ):
        """Every row a hold steps is inside the band, the row it stops at is not (or is
        the end), nothing is written past it, and the record is the one of single steps
        fed the body's own state and the held target."""
        stop, a, sigma0, omega0, gains, j = _held(
            goal, seed, bound, band_deg, band_rate, dt, reference=False
        )
        n = len(a[0]) - 1
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
        single = loop_plant(gains, bound, body, dt, *c)
        target_sigma, target_omega = np.asarray(goal, dtype=float), np.zeros(3)
        for k in range(stop):
            single.step(k, c[0][k], c[1][k], target_sigma, target_omega)
        for x, y in zip(a, c, strict=True):
            assert x.tobytes() == y.tobytes()


@needs_compiled
class TestCompiledPlant(PlantChecks):
    mode = "compiled"


class TestPythonPlant(PlantChecks):
    mode = "python"


# -- the forms against each other ----------------------------------------------------


@needs_compiled
@settings(max_examples=200, deadline=None)
@given(*RANDOM_PLANTS)
def test_the_compiled_plant_is_the_reference_to_the_bit(
    sigma, omega, seed, bound, feeds, targets, dt
):
    with kernels.selected("compiled"):
        a = _flown(sigma, omega, seed, bound, feeds, targets, dt, reference=False)
    b = _flown(sigma, omega, seed, bound, feeds, targets, dt, reference=True)
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()  # signed zeros and NaN included


def _band_values(sigma: np.ndarray, omega: np.ndarray, goal) -> tuple[float, float]:
    """The guidance's own attitude error (deg) and rate (rad/s) of a record row."""
    return math.degrees(angle_between_single(sigma, goal)), math.hypot(*omega)


@needs_compiled
@settings(max_examples=150, deadline=None)
@given(*HOLDS)
def test_the_compiled_hold_is_the_reference_to_the_bit(goal, seed, bound, band_deg, band_rate, dt):
    """The compiled hold and the reference's stop at the same step, with the same
    record."""
    with kernels.selected("compiled"):
        stop, a, *_ = _held(goal, seed, bound, band_deg, band_rate, dt, reference=False)
    stop_ref, b, *_ = _held(goal, seed, bound, band_deg, band_rate, dt, reference=True)
    assert stop == stop_ref
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()
