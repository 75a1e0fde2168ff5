"""What the controller commands at a loop tick without a fresh state.

Inputs: each measured state (stamp ns, ``sigma_BN``, ``omega_B``), each answer the
controller gave one (the target ``sigma_RN`` and the torque), and the ticks of the
stack's clock (ns). Output at a tick (:meth:`OutageControl.tick`): None while the newest
state is fresh (the controller answers states as usual); else the mode, the predicted
state and the torque to command (body axes, N m):

* ``predicting``: the PD law (eq. 11) on the predicted state towards the last target,
  held at rest (``omega_R = 0``): the body comes to rest on an attitude the guidance
  had cleared, whatever the slew was doing;
* ``braking``: ``-Kd omega`` on the predicted rate, scaled into the actuator bound
  (Basilisk's ``rateDamp``), then zero torque once the predicted rate is below
  :data:`~attitude_core.fsw.fdir.fdir_config.BRAKED_RATE_RAD_S`, so a plant that holds
  the last command holds a zero;
* ``safe_mode``: the same: the predicted rate braked (a weak actuator may not have
  stopped the body by then), then zero torque, never a braking torque left held.

Every torque commanded feeds the predictor (:mod:`.state_predictor`) with the time it
takes effect.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.contract.faults import Fault
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.fdir.fdir_config import BRAKED_RATE_RAD_S, FdirConfig
from attitude_core.fsw.fdir.state_predictor import StatePredictor
from attitude_core.fsw.fdir.state_watchdog import FdirMode, StateWatchdog

__all__ = ["OutageAnswer", "OutageControl"]

Vector = npt.NDArray[np.float64]
_ZERO = np.zeros(3)


@dataclass(frozen=True)
class OutageAnswer:
    """A tick's command: ``torque_b`` (N m) from the predicted ``sigma_bn``, ``omega_b``;
    ``opened``: the faults this tick opened."""

    mode: FdirMode
    torque_b: Vector
    sigma_bn: Vector
    omega_b: Vector
    opened: list[Fault]


class OutageControl:
    """See the module docstring. ``bound``: ``actuators.max_torque_nm`` (None:
    unlimited); ``inertia_kgm2`` and ``dt_s``: the body model and the loop step;
    ``origin_ns``: t = 0 of the fault times (default: the first state's time)."""

    def __init__(
        self,
        config: FdirConfig,
        gains: PdGains,
        bound: tuple[float, float, float] | None,
        inertia_kgm2: npt.ArrayLike,
        dt_s: float,
        origin_ns: int | None = None,
    ) -> None:
        self.watchdog = StateWatchdog(config, origin_ns)
        self.predictor = StatePredictor(inertia_kgm2, dt_s)
        self.gains = gains
        self.bound = bound
        self.target: Vector | None = None  # the last target, held at rest
        self.braked = False

    def measured(
        self,
        stamp_ns: int,
        sigma_bn: npt.ArrayLike,
        omega_b: npt.ArrayLike,
        now_ns: int | None = None,
    ) -> list[Fault]:
        """A measured state received at ``now_ns`` (default: its stamp); returns the
        fault it ends."""
        closed = self.watchdog.measured(stamp_ns, now_ns)
        if self.watchdog.last_ns == stamp_ns:
            self.predictor.measured(stamp_ns, sigma_bn, omega_b)
            self.braked = False
        return closed

    def answered(self, stamp_ns: int, sigma_t: npt.ArrayLike, torque_b: npt.ArrayLike) -> None:
        """The controller answered the state stamped ``stamp_ns`` with ``torque_b``
        towards the target ``sigma_t``."""
        self.target = np.array(sigma_t, dtype=float)
        self.predictor.commanded(stamp_ns, torque_b)

    @property
    def safe(self) -> bool:
        return self.watchdog.safe

    def tick(self, now_ns: int) -> OutageAnswer | None:
        """The command at ``now_ns`` when the newest state is stale (None: it is fresh,
        or no state has come yet)."""
        dog = self.watchdog
        if dog.last_ns is None:
            return None
        mode, opened = dog.check(now_ns)
        if mode is FdirMode.NOMINAL:
            return None
        sigma, omega = self.predictor.predict(now_ns)
        if mode is FdirMode.PREDICTING and self.target is not None:
            u = commanded_torque(self.gains, sigma, omega, self.target, _ZERO, self.bound)
        elif not self.braked:
            if float(np.linalg.norm(omega)) < BRAKED_RATE_RAD_S:
                self.braked = True
                u = _ZERO.copy()
            else:  # the D term alone: sigma_B/R = 0 with the predicted attitude as target
                u = commanded_torque(self.gains, sigma, omega, sigma, _ZERO, self.bound)
        else:
            u = _ZERO.copy()
        self.predictor.commanded(now_ns, u)
        return OutageAnswer(mode, u, sigma, omega, opened)
