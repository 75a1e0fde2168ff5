"""The offline loop's controller and plant for one run, recording as they go.

One :meth:`step` at step ``k``: the PD command (eq. 11, scaled into the controller's
bound) from the state the loop is fed and the target, the plant's per-axis clip, row
``k`` of the record (torque, target) and, unless ``k`` is the last row, one RK4 step of
the body (eqs. 3-4, with the shadow switch of eq. 2) from row ``k`` of ``sigma`` and
``omega`` to row ``k + 1``. Row 0 holds the initial state.

:meth:`hold` takes those steps one after the other, fed the body's own state (perfect
knowledge) and one target, while the body stays inside a band about a goal (attitude
error, deg, and rate norm, rad/s): the offline loop's steps while the guidance holds the
body on the goal and would answer every state with the same target until the body leaves
its arrival band (:meth:`attitude_core.fsw.guidance.guidance.Guidance.hold_band`). It stops
:data:`HOLD_GUARD` (relative) short of the band's edges, so the guidance itself judges
every state near them.

:class:`LoopPlantReference` composes the per-step references
(:func:`attitude_core.fsw.control.pd.pd_command_reference`,
:func:`attitude_core.world.actuator.clip_to_bound`,
:meth:`attitude_core.world.rigid_body.RigidBody.step_reference`), whatever kernels the
process runs; the compiled ``_kernels.LoopPlant`` (``kernels/loop_plant.pxi``) does the
same in one call (same operations, same order: equal to the bit,
``tests/core/test_loop_plant.py``). :func:`loop_plant` gives the one
:data:`attitude_core.kernels.compiled` selects.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.fsw.control.pd import PdGains, pd_command_reference
from attitude_core.models.mrp import Vec3Like, angle_between_single_reference
from attitude_core.world.actuator import clip_to_bound
from attitude_core.world.rigid_body import RigidBody

__all__ = ["HOLD_GUARD", "LoopPlant", "LoopPlantReference", "loop_plant"]

HOLD_GUARD = 1e-9
"""A hold stops where the body's error or rate is within this share of the band's edge:
the guidance's own comparison (``math.hypot`` for the rate) decides there."""

_Rows = npt.NDArray[np.float64]


class LoopPlant(Protocol):
    def step(
        self,
        k: int,
        sigma_m: Vec3Like,
        omega_m: Vec3Like,
        target_sigma: Vec3Like,
        target_omega: Vec3Like,
    ) -> None: ...

    def hold(
        self,
        k: int,
        stop: int,
        goal: Vec3Like,
        target_sigma: Vec3Like,
        target_omega: Vec3Like,
        band_deg: float,
        band_rate: float,
    ) -> int: ...


class LoopPlantReference:
    """The module docstring's step from the per-step functions (see there)."""

    def __init__(
        self,
        gains: PdGains,
        bound: tuple[float, float, float] | None,
        body: RigidBody,
        dt: float,
        sigma: _Rows,
        omega: _Rows,
        torque: _Rows,
        sigma_t: _Rows,
        omega_t: _Rows,
    ) -> None:
        self.gains, self.bound, self.body, self.dt = gains, bound, body, dt
        self.sigma, self.omega, self.torque = sigma, omega, torque
        self.sigma_t, self.omega_t = sigma_t, omega_t

    def step(
        self,
        k: int,
        sigma_m: Vec3Like,
        omega_m: Vec3Like,
        target_sigma: Vec3Like,
        target_omega: Vec3Like,
    ) -> None:
        g = self.gains
        u1, u2, u3, _ = pd_command_reference(
            g.kp_flat, g.kd_flat, sigma_m, omega_m, target_sigma, target_omega, self.bound
        )
        # the plant's own bound (a no-op after the scaling)
        u, _ = clip_to_bound(np.array((u1, u2, u3)), self.bound)
        self.torque[k] = u
        self.sigma_t[k], self.omega_t[k] = target_sigma, target_omega
        if k + 1 < len(self.sigma):
            body = self.body
            body.sigma_bn, body.omega_b = self.sigma[k].copy(), self.omega[k].copy()
            body.step_reference(u, self.dt)
            self.sigma[k + 1], self.omega[k + 1] = body.sigma_bn, body.omega_b

    def hold(
        self,
        k: int,
        stop: int,
        goal: Vec3Like,
        target_sigma: Vec3Like,
        target_omega: Vec3Like,
        band_deg: float,
        band_rate: float,
    ) -> int:
        """Steps ``k, k + 1, ...`` (before ``stop``) fed the body's own state and one
        target while the body is inside the band (the module docstring); returns the
        first step not taken."""
        e_lim = band_deg * (1.0 - HOLD_GUARD)
        r_lim = band_rate * (1.0 - HOLD_GUARD)
        while k < stop:
            s, w = self.sigma[k], self.omega[k]
            e = angle_between_single_reference(s, goal) * (180.0 / math.pi)
            w1, w2, w3 = float(w[0]), float(w[1]), float(w[2])
            r = math.sqrt(w1 * w1 + w2 * w2 + w3 * w3)
            if not (e <= e_lim and r <= r_lim):  # NaN leaves too
                break
            self.step(k, s, w, target_sigma, target_omega)
            k += 1
        return k


def loop_plant(
    gains: PdGains,
    bound: tuple[float, float, float] | None,
    body: RigidBody,
    dt: float,
    sigma: _Rows,
    omega: _Rows,
    torque: _Rows,
    sigma_t: _Rows,
    omega_t: _Rows,
) -> LoopPlant:
    """The compiled plant when the kernels are built and selected, else the reference;
    both write into the given ``(n + 1, 3)`` float arrays, whose row 0 of ``sigma`` and
    ``omega`` must hold ``body``'s initial state."""
    k = kernels.compiled
    if k is None:
        return LoopPlantReference(gains, bound, body, dt, sigma, omega, torque, sigma_t, omega_t)
    plant: LoopPlant = k.LoopPlant(
        gains.kp_flat,
        gains.kd_flat,
        bound,
        body.inertia_flat,
        body.inertia_inv_flat,
        dt,
        sigma,
        omega,
        torque,
        sigma_t,
        omega_t,
    )
    return plant
