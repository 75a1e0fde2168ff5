"""The onboard state of one run: the sensors on the true body and the MEKF behind them.

:class:`OnboardEstimation` is what the offline loop feeds its guidance and controller
with when a scenario declares ``sensors.*``: at each step the true state is measured
(:class:`attitude_core.world.sensors.SensorSuite`) and the measurement filtered
(:class:`attitude_core.fsw.estimation.mekf.Mekf`); the estimate, its 3-sigma and its NEES against
the truth are kept for the run's record. The estimator node runs the same filter on
the simulator's measurements.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.estimation.mekf import Estimate, Mekf, MekfConfig, nees
from attitude_core.models.sensor_spec import SensorSpec
from attitude_core.world.sensors import SensorSuite

__all__ = ["OnboardEstimation"]

_Floats = npt.NDArray[np.float64]


class OnboardEstimation:
    """Sensors and filter over ``n_rows`` steps of ``dt_s`` (see module docstring)."""

    def __init__(
        self,
        spec: SensorSpec,
        dt_s: float,
        n_rows: int,
        blinded: Callable[[float, _Floats], bool] | None = None,
    ) -> None:
        self.sensors = SensorSuite(spec, dt_s)
        self.blinded = blinded  # the tracker's own keep-out, judged on the sky
        self.tracker_times: list[float] = []  # the star tracker samples taken
        self.filter = Mekf(MekfConfig.from_spec(spec, dt_s))
        nan3 = np.full((n_rows, 3), np.nan)
        self.sigma_bn: _Floats = nan3.copy()
        self.omega_b: _Floats = nan3.copy()
        self.attitude_3sigma_deg: _Floats = np.full(n_rows, np.nan)
        self.nees: _Floats = np.full(n_rows, np.nan)

    def sense(self, k: int, t_s: float, sigma_bn: _Floats, omega_b: _Floats) -> Estimate | None:
        """Measure the true state of row ``k`` at ``t_s`` and filter it; None until the
        filter has its first star tracker fix."""
        bias = self.sensors.bias_rad_s.copy()  # the bias of this sample
        blind = self.blinded is not None and self.blinded(t_s, sigma_bn)
        m = self.sensors.measure(t_s, sigma_bn, omega_b, blind)
        if m.star_tracker_quat is not None:
            self.tracker_times.append(t_s)
        est = self.filter.step(t_s, m.gyro_rad_s, m.star_tracker_quat)
        if est is not None:
            self.sigma_bn[k] = est.sigma_bn
            self.omega_b[k] = est.omega_b
            self.attitude_3sigma_deg[k] = est.attitude_3sigma_deg
            self.nees[k] = nees(est, sigma_bn, bias)
        return est
