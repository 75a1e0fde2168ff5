"""The offline loop's controller and plant for one run, recording as they go.

One :meth:`step` at step ``k``: the PD command (eq. 11, scaled into the controller's
bound) from the state the loop is fed and the target, the plant's per-axis clip, row
``k`` of the record (torque, target) and, unless ``k`` is the last row, one RK4 step of
the body (eqs. 3-4, with the shadow switch of eq. 2) from row ``k`` of ``sigma`` and
``omega`` to row ``k + 1``. Row 0 holds the initial state.

:class:`LoopPlantReference` composes the per-step functions
(:func:`attitude_core.gnc.control.commanded_torque`,
:func:`attitude_core.gnc.actuators.clip_to_bound`,
:meth:`attitude_core.gnc.dynamics.RigidBody.step`); the compiled
``_kernels.LoopPlant`` does the same in one call (same operations, same order: equal to
the bit, ``tests/core/test_loop_plant.py``). :func:`loop_plant` gives the one
:data:`attitude_core.gnc.kernels.ACTIVE` selects.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt

from attitude_core.gnc import kernels
from attitude_core.gnc.actuators import clip_to_bound
from attitude_core.gnc.control import PdGains, commanded_torque
from attitude_core.gnc.dynamics import RigidBody
from attitude_core.gnc.mrp import Vec3Like

__all__ = ["LoopPlant", "LoopPlantReference", "loop_plant"]

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
        u = commanded_torque(self.gains, sigma_m, omega_m, target_sigma, target_omega, self.bound)
        u, _ = clip_to_bound(u, self.bound)  # the plant's own bound (a no-op after the scaling)
        self.torque[k] = u
        self.sigma_t[k], self.omega_t[k] = target_sigma, target_omega
        if k + 1 < len(self.sigma):
            body = self.body
            body.sigma_bn, body.omega_b = self.sigma[k].copy(), self.omega[k].copy()
            body.step(u, self.dt)
            self.sigma[k + 1], self.omega[k + 1] = body.sigma_bn, body.omega_b


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
