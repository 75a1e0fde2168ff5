"""The estimator node's logic without ROS: gyro and star tracker samples in, estimates
out, in stamp order.

Every gyro sample (``/spacecraft/imu``) is one filter step at its stamp. The star
tracker sample of a step arrives on its own topic, so it may come before or after the
gyro sample of the same stamp: a step whose stamp is a star tracker sample time of the
declared schedule (:func:`attitude_core.models.sensor_spec.star_tracker_due`) waits for that
sample up to ``wait_s`` of wall time, then is filtered without it (``lost``). A star
tracker sample whose step was already filtered is ``late`` and dropped; one at a stamp
off the schedule is used if its gyro sample is still pending. Gyro samples older than
the last step filtered are ``stale`` and dropped; a gyro sample at the last step's
stamp is the simulator re-sending its state (its torque was lost): the same estimate is
published again. The estimate of a step carries its
stamp, so the planner and the controller answer the simulator's step as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.estimation.mekf import Estimate, Mekf, MekfConfig
from attitude_core.models.sensor_spec import SensorSpec, star_tracker_due

__all__ = ["StampedEstimate", "EstimatorStepper"]

_Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class StampedEstimate:
    stamp_ns: int
    estimate: Estimate
    star_tracker_used: bool


class EstimatorStepper:
    """Pairs the samples by stamp and runs the MEKF (see the module docstring)."""

    def __init__(self, spec: SensorSpec, dt_s: float, wait_s: float) -> None:
        self.spec, self.dt_s, self.wait_s = spec, dt_s, wait_s
        self.filter = Mekf(MekfConfig.from_spec(spec, dt_s))
        self._gyro: dict[int, tuple[float, _Floats]] = {}  # stamp -> (arrival, sample)
        self._tracker: dict[int, _Floats] = {}
        self.last_stamp_ns = -1
        self.lost = 0  # due star tracker samples that never came in time
        self.late = 0  # star tracker samples after their step
        self.stale = 0  # gyro samples older than the last step
        self.updates = 0  # steps filtered with a star tracker sample
        self.last: StampedEstimate | None = None

    def on_gyro(self, now_s: float, stamp_ns: int, gyro_rad_s: _Floats) -> list[StampedEstimate]:
        if stamp_ns == self.last_stamp_ns and self.last is not None:
            return [self.last]  # a re-sent state: the same answer
        if stamp_ns <= self.last_stamp_ns:
            self.stale += 1
            return []
        self._gyro.setdefault(stamp_ns, (now_s, np.asarray(gyro_rad_s, dtype=float)))
        return self.poll(now_s)

    def on_star_tracker(self, now_s: float, stamp_ns: int, quat: _Floats) -> list[StampedEstimate]:
        if stamp_ns == self.last_stamp_ns:
            return []  # a re-sent state's sample: its step is filtered
        if stamp_ns < self.last_stamp_ns:
            self.late += 1
            return []
        self._tracker[stamp_ns] = np.asarray(quat, dtype=float)
        return self.poll(now_s)

    def poll(self, now_s: float) -> list[StampedEstimate]:
        """Filter every pending step that is complete or has waited long enough."""
        out: list[StampedEstimate] = []
        while self._gyro:
            stamp = min(self._gyro)
            arrived, gyro = self._gyro[stamp]
            quat = self._tracker.pop(stamp, None)
            if quat is None and star_tracker_due(
                stamp / NS_PER_S, self.spec.star_tracker_rate_hz, self.dt_s
            ):
                if now_s - arrived < self.wait_s:
                    break  # its star tracker sample may still come
                self.lost += 1
            del self._gyro[stamp]
            for old in [s for s in self._tracker if s < stamp]:
                del self._tracker[old]
                self.late += 1
            self.last_stamp_ns = stamp
            est = self.filter.step(stamp / NS_PER_S, gyro, quat)
            if quat is not None:
                self.updates += 1
            if est is not None:
                self.last = StampedEstimate(stamp, est, quat is not None)
                out.append(self.last)
        return out
