"""The flight software's body model: the state predicted from the last measured one.

Inputs: the last measured state (stamp, ns; ``sigma_BN``; ``omega_B``, rad/s) and every
torque commanded (body axes, N m) with the time it takes effect (ns, the stack's clock:
the stamp of the state it answers, or the tick it was commanded at). Output: the state
at a later time, propagated in steps of at most ``dt_s`` with the torque in effect over
each (eqs. 3-4, :func:`attitude_core.models.body_dynamics.rk4_step`). The inertia is the
declared one; a plant that applies what it is told, on the loop's grid, is predicted to
rounding.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.fdir.fdir_config import NS_PER_S
from attitude_core.models.body_dynamics import rk4_step

__all__ = ["StatePredictor"]

Vector = npt.NDArray[np.float64]

MAX_COMMANDS = 100_000
"""Commands kept for the propagation (at most this many past the last measured state)."""


class StatePredictor:
    """See the module docstring. ``inertia_kgm2``: 3x3, body axes; ``dt_s``: the step."""

    def __init__(self, inertia_kgm2: npt.ArrayLike, dt_s: float) -> None:
        self.inertia = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.dt_ns = round(dt_s * NS_PER_S)
        self.t_ns: int | None = None  # time of the predicted state
        self.measured_ns: int | None = None  # stamp of the last measured state
        self.sigma_bn: Vector = np.zeros(3)
        self.omega_b: Vector = np.zeros(3)
        # (effective time ns, torque), increasing times; the first is in effect at t_ns
        self.commands: deque[tuple[int, Vector]] = deque(maxlen=MAX_COMMANDS)

    def measured(self, stamp_ns: int, sigma_bn: npt.ArrayLike, omega_b: npt.ArrayLike) -> None:
        """A measured state: the prediction restarts from it."""
        self.t_ns = self.measured_ns = stamp_ns
        self.sigma_bn = np.array(sigma_bn, dtype=float)
        self.omega_b = np.array(omega_b, dtype=float)
        self._prune()

    def commanded(self, t_ns: int, torque_b: npt.ArrayLike) -> None:
        """``torque_b`` is commanded, in effect from ``t_ns`` (replaces later ones)."""
        while self.commands and self.commands[-1][0] >= t_ns:
            self.commands.pop()
        self.commands.append((t_ns, np.array(torque_b, dtype=float)))

    def torque_at(self, t_ns: int) -> Vector:
        """The torque in effect at ``t_ns`` (zero before the first command)."""
        u = np.zeros(3)
        for t_c, u_c in self.commands:
            if t_c > t_ns:
                break
            u = u_c
        return u

    def predict(self, t_ns: int) -> tuple[Vector, Vector]:
        """The state at ``t_ns`` (not before the last measured or predicted time); the
        prediction is kept, so successive calls propagate only the new interval."""
        if self.t_ns is None:
            raise ValueError("no measured state to predict from")
        while self.t_ns < t_ns:
            u = self.torque_at(self.t_ns)
            nxt = min(t_ns, self.t_ns + self.dt_ns)
            later = [t_c for t_c, _ in self.commands if self.t_ns < t_c < nxt]
            if later:
                nxt = later[0]
            self.sigma_bn, self.omega_b = rk4_step(
                self.inertia,
                self.inertia_inv,
                self.sigma_bn,
                self.omega_b,
                u,
                (nxt - self.t_ns) / NS_PER_S,
            )
            self.t_ns = nxt
        return self.sigma_bn.copy(), self.omega_b.copy()

    def _prune(self) -> None:
        """Drop commands superseded before the last measured state (a later, delayed
        state may still need those after it)."""
        t = self.measured_ns
        if t is None:
            return
        while len(self.commands) > 1 and self.commands[1][0] <= t:
            self.commands.popleft()
