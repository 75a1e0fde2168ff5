"""PD attitude tracking law (paper eq. 11).

``u = -Kp sigma_e - Kd omega_e`` with ``sigma_e = sigma_B/R`` (the MRP of the body
relative to the target frame R, short way, ``|sigma_e| <= 1``) and
``omega_e = omega_B - C_BR omega_R`` (target rate mapped into body axes).
Gains default to ``Kp = 5.5 J``, ``Kd = 3.1 J`` (paper Table 1). With an actuator
bound the command is scaled into it, direction kept (:func:`commanded_torque`).
:func:`commanded_torque` runs the compiled kernel (:mod:`attitude_core.kernels`,
``kernels/control.pxi``); :func:`pd_command_reference` is its reference, the same
operations in Python floats (equal to the bit), and :func:`pd_torque` with
``scale_to_bound`` the same law in NumPy (its sums may round otherwise in the last bit).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.models.mrp import (
    Vec3Like,
    dcm_from_mrp_single,
    dcm_rows_from_mrp,
    relative,
    relative_single_reference,
)

__all__ = [
    "PdGains",
    "pd_torque",
    "pd_command_reference",
    "commanded_torque",
    "tracking_errors",
]


class PdGains:
    """Proportional and derivative gain matrices (N m per MRP, N m s per rad)."""

    def __init__(self, kp: np.ndarray, kd: np.ndarray) -> None:
        self.kp = np.asarray(kp, dtype=float).reshape(3, 3)
        self.kd = np.asarray(kd, dtype=float).reshape(3, 3)
        self.kp_flat = tuple(self.kp.ravel().tolist())  # row-major, for the kernel
        self.kd_flat = tuple(self.kd.ravel().tolist())

    @classmethod
    def from_inertia(
        cls, inertia_kgm2: np.ndarray, kp_over_j: float = 5.5, kd_over_j: float = 3.1
    ) -> PdGains:
        j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        return cls(kp_over_j * j, kd_over_j * j)


def tracking_errors(
    sigma_bn: npt.ArrayLike, omega_b: npt.ArrayLike, sigma_rn: npt.ArrayLike, omega_r: npt.ArrayLike
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Attitude and rate errors ``(sigma_B/R, omega_B - C_BR omega_R)`` in body axes.

    ``omega_r`` is the target (reference) rate in target-frame axes, rad/s.
    """
    sigma_br = relative(sigma_bn, sigma_rn)
    c_br = dcm_from_mrp_single(sigma_br)
    omega_e = np.asarray(omega_b, dtype=float) - c_br @ np.asarray(omega_r, dtype=float)
    return sigma_br, omega_e


def pd_torque(
    gains: PdGains,
    sigma_bn: npt.ArrayLike,
    omega_b: npt.ArrayLike,
    sigma_rn: npt.ArrayLike,
    omega_r: npt.ArrayLike,
) -> npt.NDArray[np.float64]:
    """Control torque ``u`` in body axes, N m (eq. 11)."""
    sigma_e, omega_e = tracking_errors(sigma_bn, omega_b, sigma_rn, omega_r)
    return -(gains.kp @ sigma_e) - gains.kd @ omega_e


def commanded_torque(
    gains: PdGains,
    sigma_bn: npt.ArrayLike,
    omega_b: npt.ArrayLike,
    sigma_rn: npt.ArrayLike,
    omega_r: npt.ArrayLike,
    max_torque_nm: tuple[float, float, float] | None = None,
) -> npt.NDArray[np.float64]:
    """The controller's command: eq. 11, scaled into ``max_torque_nm`` (per body axis,
    N m; None: unlimited) with its direction kept (``saturation.scale_to_bound``)."""
    k = kernels.compiled
    command: Callable[..., tuple[float, float, float, bool]] = (
        pd_command_reference if k is None else k.pd_command
    )
    u1, u2, u3, _ = command(
        gains.kp_flat, gains.kd_flat, sigma_bn, omega_b, sigma_rn, omega_r, max_torque_nm
    )
    return np.array((u1, u2, u3))


def pd_command_reference(
    kp: tuple[float, ...],
    kd: tuple[float, ...],
    sigma_bn: Vec3Like,
    omega_b: Vec3Like,
    sigma_rn: Vec3Like,
    omega_r: Vec3Like,
    bound: tuple[float, float, float] | None,
) -> tuple[float, float, float, bool]:
    """Eq. 11 scaled into the bound, in Python floats: ``(u1, u2, u3, saturated)``, N m,
    body axes (the compiled ``_kernels.pd_command``'s reference, the same operations in
    the same order: equal to the bit).

    ``kp``, ``kd``: the gain matrices row-major (9 floats, :attr:`PdGains.kp_flat`);
    ``sigma_rn``, ``omega_r``: the target and its rate in target axes; ``bound``: 3
    per-axis limits or None. The error is ``sigma_B/R`` (short way) and
    ``omega_B - C_BR omega_R``; the scaling divides by the largest ``|u_i| / bound_i``
    when it exceeds 1 (:func:`scale_to_bound`'s factor).
    """
    e1, e2, e3 = relative_single_reference(sigma_bn, sigma_rn)
    c = dcm_rows_from_mrp((e1, e2, e3))
    o1, o2, o3 = float(omega_r[0]), float(omega_r[1]), float(omega_r[2])
    w1 = float(omega_b[0]) - (c[0][0] * o1 + c[0][1] * o2 + c[0][2] * o3)
    w2 = float(omega_b[1]) - (c[1][0] * o1 + c[1][1] * o2 + c[1][2] * o3)
    w3 = float(omega_b[2]) - (c[2][0] * o1 + c[2][1] * o2 + c[2][2] * o3)
    g, d = kp, kd
    u = [
        -(g[3 * i] * e1 + g[3 * i + 1] * e2 + g[3 * i + 2] * e3)
        - (d[3 * i] * w1 + d[3 * i + 1] * w2 + d[3 * i + 2] * w3)
        for i in range(3)
    ]
    if bound is None:
        return u[0], u[1], u[2], False
    b = (float(bound[0]), float(bound[1]), float(bound[2]))
    ratio = abs(u[0]) / b[0]
    for i in (1, 2):
        r = abs(u[i]) / b[i]
        if r > ratio:
            ratio = r
    if ratio <= 1.0:
        return u[0], u[1], u[2], False
    return u[0] / ratio, u[1] / ratio, u[2] / ratio, True
