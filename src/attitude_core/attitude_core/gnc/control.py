"""PD attitude tracking law (paper eq. 11).

``u = -Kp sigma_e - Kd omega_e`` with ``sigma_e = sigma_B/R`` (the MRP of the body
relative to the target frame R, short way, ``|sigma_e| <= 1``) and
``omega_e = omega_B - C_BR omega_R`` (target rate mapped into body axes).
Gains default to ``Kp = 5.5 J``, ``Kd = 3.1 J`` (paper Table 1). With an actuator
bound the command is scaled into it, direction kept (:func:`commanded_torque`).
:func:`commanded_torque` runs the compiled kernel (:mod:`attitude_core.gnc.kernels`);
:func:`pd_torque` with ``scale_to_bound`` is its reference.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core.gnc import kernels
from attitude_core.gnc.actuators import scale_to_bound
from attitude_core.gnc.mrp import dcm_from_mrp_single, relative

__all__ = ["PdGains", "pd_torque", "commanded_torque", "tracking_errors"]


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
    N m; None: unlimited) with its direction kept (``actuators.scale_to_bound``)."""
    k = kernels.compiled
    if k is None:
        u, _ = scale_to_bound(pd_torque(gains, sigma_bn, omega_b, sigma_rn, omega_r), max_torque_nm)
        return u
    u1, u2, u3, _ = k.pd_command(
        gains.kp_flat, gains.kd_flat, sigma_bn, omega_b, sigma_rn, omega_r, max_torque_nm
    )
    return np.array((u1, u2, u3))
