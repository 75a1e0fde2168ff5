"""Multiplicative extended Kalman filter (MEKF): attitude and gyro bias from a star tracker
and a rate gyro.

After Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control* (2014), the MEKF with gyro-bias estimation. Six error states
``x = [delta_theta, delta_b]``:

* ``delta_theta`` (3, rad, BODY axes): ``q_true = q_est (x) dq(delta_theta)`` with the
  Hamilton product of :func:`attitude_core.models.quaternion.quat_mul`, i.e.
  ``Rotation.from_quat(q_true) == Rotation.from_quat(q_est) * Rotation.from_rotvec(dtheta)``
  (the star tracker's error convention, :mod:`attitude_core.world.sensors`). With
  ``A = C_BN`` this is the book's ``A(q_true) = A(dq(delta_theta)) A(q_est)``,
  ``A(dq) ~ I - [delta_theta x]``: the same ``delta_theta``, written there with the
  reverse-order quaternion product;
* ``delta_b`` (3, rad/s): ``b_true - b_est``.

Gyro model ``omega_meas = omega + b + v`` (ARW density ``sigma_v^2 = gyro_noise^2 dt``,
rad^2/s), bias random walk ``b_dot = u`` (``sigma_u^2``, rad^2/s^3). Error dynamics
``delta_theta_dot = -[omega_hat x] delta_theta - delta_b - v``, ``delta_b_dot = u``, whose
discrete form over ``dt`` (``omega_hat`` held at the mean of the interval's two gyro
samples minus the bias estimate, with which the quaternion is propagated exactly) is
``Phi = [[exp(-[w x] dt), -int_0^dt exp(-[w x] s) ds], [0, I]]`` (closed form,
:func:`transition_matrix`) and, for isotropic noises,
``Qd = [[(sv^2 dt + su^2 dt^3/3) I, -(su^2 dt^2/2) I], [-(su^2 dt^2/2) I, su^2 dt I]]``
(:func:`process_noise`). Star tracker update: ``H = [I3 0]``, ``R = diag(noise^2)``, the
residual the body-axes rotation vector of ``q_est^-1 (x) q_meas``; Joseph-form covariance
update, then the reset ``q <- q (x) dq(dtheta_hat)``, ``b <- b + db_hat`` (the reset's
second-order covariance correction is neglected, as is usual).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import Vec3Like, angle_between_single, quat_from_mrp
from attitude_core.models.quaternion import (
    Quat,
    quat_conj,
    quat_from_rotvec,
    quat_mul,
    rotvec_from_quat,
)
from attitude_core.models.sensor_spec import SensorSpec, star_tracker_sample_steps

__all__ = [
    "MekfConfig",
    "Estimate",
    "Mekf",
    "transition_matrix",
    "process_noise",
    "steady_state_covariance",
    "nees",
    "attitude_error_rad",
]

_Floats = npt.NDArray[np.float64]
_QuatLike = Sequence[float] | _Floats


@dataclass(frozen=True)
class MekfConfig:
    """The filter's noise model (what it believes of the sensors). SI units."""

    dt_s: float
    """The gyro's sampling interval: converts the per-sample noise to a density."""
    star_tracker_noise_rad: tuple[float, float, float]
    gyro_noise_rad_s: float
    """1-sigma per sample (discrete); the ARW density is ``gyro_noise^2 * dt_s``."""
    gyro_bias_walk_rad_s2: float
    gyro_bias_prior_rad_s: float

    @classmethod
    def from_spec(cls, spec: SensorSpec, dt_s: float) -> MekfConfig:
        """The noise model of the declared sensors (a filter matched to the truth)."""
        noise = spec.star_tracker_noise_rad
        return cls(
            dt_s=float(dt_s),
            star_tracker_noise_rad=(float(noise[0]), float(noise[1]), float(noise[2])),
            gyro_noise_rad_s=float(spec.gyro_noise_rad_s),
            gyro_bias_walk_rad_s2=float(spec.gyro_bias_walk_rad_s2),
            gyro_bias_prior_rad_s=float(spec.gyro_bias_prior_rad_s),
        )

    @property
    def arw_density(self) -> float:
        """``sigma_v^2 = gyro_noise^2 * dt_s``, rad^2/s."""
        return self.gyro_noise_rad_s**2 * self.dt_s


@dataclass(frozen=True)
class Estimate:
    """The filter's output at ``t_s`` (after that step's update, if any)."""

    t_s: float
    sigma_bn: _Floats
    """(3,) principal MRP, ``|sigma| <= 1``."""
    quat: _Floats
    """(4,) scalar-last ``q_BN``, ``w >= 0``."""
    omega_b: _Floats
    """(3,) the last gyro sample minus the bias estimate, body axes, rad/s."""
    bias_rad_s: _Floats
    """(3,) estimated gyro bias, rad/s."""
    covariance: _Floats
    """(6, 6) over ``[delta_theta (rad, body axes), delta_b (rad/s)]``."""

    @property
    def attitude_3sigma_deg(self) -> float:
        """``3 sqrt(trace P_att)``, deg: a bound on the pointing error of any boresight."""
        p = self.covariance
        return math.degrees(3.0 * math.sqrt(float(p[0, 0] + p[1, 1] + p[2, 2])))


def _phi_blocks(w1: float, w2: float, w3: float, dt: float) -> list[list[float]]:
    """Rows of ``Phi = [[A, B], [0, I]]`` (6 x 6) for the rate ``w`` held over ``dt``:
    ``A = exp(-[w x] dt) = I - s [w x] + c [w x]^2``,
    ``B = -int_0^dt exp(-[w x] t) dt = -dt I + c [w x] - d [w x]^2`` with
    ``s = sin(x)/n``, ``c = (1 - cos x)/n^2``, ``d = (x - sin x)/n^3``, ``n = |w|``, ``x = n dt``.
    """
    n2 = w1 * w1 + w2 * w2 + w3 * w3
    x2 = n2 * dt * dt
    if x2 < 1e-4:  # series in x = n dt: truncation error below 1e-15 relative
        s = dt * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0))
        c = dt * dt * (0.5 - x2 / 24.0 * (1.0 - x2 / 30.0))
        d = dt * dt * dt * (1.0 / 6.0 - x2 / 120.0 * (1.0 - x2 / 42.0))
    else:
        n = math.sqrt(n2)
        x = n * dt
        sx = math.sin(x)
        s = sx / n
        c = (1.0 - math.cos(x)) / n2
        d = (x - sx) / (n2 * n)
    # [w x]^2 = w w^T - n2 I
    a0 = 1.0 - c * n2
    b0 = -dt + d * n2
    c12, c13, c23 = w1 * w2, w1 * w3, w2 * w3
    return [
        [a0 + c * w1 * w1, c * c12 + s * w3, c * c13 - s * w2,
         b0 - d * w1 * w1, -d * c12 - c * w3, -d * c13 + c * w2],
        [c * c12 - s * w3, a0 + c * w2 * w2, c * c23 + s * w1,
         -d * c12 + c * w3, b0 - d * w2 * w2, -d * c23 - c * w1],
        [c * c13 + s * w2, c * c23 - s * w1, a0 + c * w3 * w3,
         -d * c13 - c * w2, -d * c23 + c * w1, b0 - d * w3 * w3],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    ]  # fmt: skip


def transition_matrix(omega_b: Vec3Like, dt_s: float) -> _Floats:
    """Discrete error-state transition ``Phi`` (6 x 6) for the bias-corrected rate
    ``omega_b`` (rad/s) held over ``dt_s``: ``expm([[-[w x], -I], [0, 0]] dt)``, exactly."""
    return np.array(_phi_blocks(float(omega_b[0]), float(omega_b[1]), float(omega_b[2]), dt_s))


def process_noise(cfg: MekfConfig, dt_s: float) -> _Floats:
    """Discrete process noise ``Qd`` (6 x 6) over ``dt_s`` (exact for a zero rate)."""
    sv2 = cfg.arw_density
    su2 = cfg.gyro_bias_walk_rad_s2**2
    eye = np.eye(3)
    q11 = (sv2 * dt_s + su2 * dt_s**3 / 3.0) * eye
    q12 = -(su2 * dt_s**2 / 2.0) * eye
    qd: _Floats = np.block([[q11, q12], [q12, su2 * dt_s * eye]])
    return qd


class Mekf:
    """The MEKF (module docstring). Call :meth:`step` once per simulation step."""

    def __init__(self, cfg: MekfConfig) -> None:
        if not cfg.dt_s > 0.0:
            raise ValueError(f"dt_s must be > 0, got {cfg.dt_s!r}")
        if len(cfg.star_tracker_noise_rad) != 3 or not all(
            v > 0.0 for v in cfg.star_tracker_noise_rad
        ):
            raise ValueError(f"star_tracker_noise_rad must be 3 values > 0, got "
                             f"{cfg.star_tracker_noise_rad!r}")  # fmt: skip
        if not cfg.gyro_bias_prior_rad_s > 0.0:
            raise ValueError(
                f"gyro_bias_prior_rad_s must be > 0, got {cfg.gyro_bias_prior_rad_s!r}"
            )
        if cfg.gyro_noise_rad_s < 0.0 or cfg.gyro_bias_walk_rad_s2 < 0.0:
            raise ValueError("gyro_noise_rad_s and gyro_bias_walk_rad_s2 must be >= 0")
        self.cfg = cfg
        self._r_diag: _Floats = np.array(cfg.star_tracker_noise_rad, dtype=float) ** 2
        self._r: _Floats = np.diag(self._r_diag)
        self._eye6: _Floats = np.eye(6)
        self._q: Quat | None = None
        self._b: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._p: _Floats = np.zeros((6, 6))
        self._t = 0.0
        self._gyro: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._qd_dt = -1.0
        self._qd: _Floats = np.zeros((6, 6))

    @property
    def initialized(self) -> bool:
        """Whether the first star tracker sample has arrived."""
        return self._q is not None

    def set_star_tracker_noise(self, noise_rad: Sequence[float]) -> None:
        """Filter the next star tracker samples with this 1-sigma (rad, about body x, y,
        z): what a tracker declares with its sample (the estimator node)."""
        r = np.array([float(x) for x in noise_rad], dtype=float)
        if r.shape != (3,) or not (np.isfinite(r).all() and (r > 0.0).all()):
            raise ValueError(f"star tracker noise must be 3 values > 0, got {list(noise_rad)}")
        self._r_diag = r**2
        self._r = np.diag(self._r_diag)

    def step(
        self,
        t_s: float,
        gyro_rad_s: Vec3Like,
        star_tracker_quat: _QuatLike | None = None,
    ) -> Estimate | None:
        """Propagate to ``t_s`` with this step's gyro sample, then update with the star
        tracker sample if there is one. None until the first star tracker sample."""
        t = float(t_s)
        g = (float(gyro_rad_s[0]), float(gyro_rad_s[1]), float(gyro_rad_s[2]))
        if self._q is None:
            if star_tracker_quat is None:
                return None
            self._initialize(t, g, star_tracker_quat)
        else:
            dt = t - self._t
            if not dt > 0.0:
                raise ValueError(f"step: t_s must increase, got {t!r} after {self._t!r}")
            self._propagate(dt, g)
            self._t, self._gyro = t, g
            if star_tracker_quat is not None:
                self._update(star_tracker_quat)
        return self._estimate()

    def _initialize(self, t: float, g: tuple[float, float, float], q_meas: _QuatLike) -> None:
        q = (float(q_meas[0]), float(q_meas[1]), float(q_meas[2]), float(q_meas[3]))
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        self._q = (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
        self._b = (0.0, 0.0, 0.0)
        prior2 = self.cfg.gyro_bias_prior_rad_s**2
        self._p = np.diag(np.concatenate([self._r_diag, [prior2, prior2, prior2]]))
        self._t, self._gyro = t, g

    def _propagate(self, dt: float, g: tuple[float, float, float]) -> None:
        """Attitude: exact for the mean of the two gyro samples (minus the bias) held over
        ``dt``; covariance ``P <- Phi P Phi^T + Qd``."""
        assert self._q is not None
        gp, b = self._gyro, self._b
        w1 = 0.5 * (gp[0] + g[0]) - b[0]
        w2 = 0.5 * (gp[1] + g[1]) - b[1]
        w3 = 0.5 * (gp[2] + g[2]) - b[2]
        self._q = quat_mul(self._q, quat_from_rotvec((w1 * dt, w2 * dt, w3 * dt)))
        phi = np.array(_phi_blocks(w1, w2, w3, dt))
        if abs(dt - self._qd_dt) > 1e-9 * dt:  # k dt - (k - 1) dt differs in the last bits
            self._qd, self._qd_dt = process_noise(self.cfg, dt), dt
        self._p = phi @ self._p @ phi.T + self._qd

    def _update(self, q_meas: _QuatLike) -> None:
        """Star tracker update (``H = [I3 0]``), Joseph form, then the reset."""
        assert self._q is not None
        residual = rotvec_from_quat(quat_mul(quat_conj(self._q), q_meas))
        p = self._p
        k = p[:, :3] @ _inv_sym3(p[:3, :3] + self._r)  # (6, 3)
        ikh = self._eye6.copy()
        ikh[:, :3] -= k
        p = ikh @ p @ ikh.T + (k * self._r_diag) @ k.T
        self._p = 0.5 * (p + p.T)
        dx = (k @ np.array(residual)).tolist()
        q = quat_mul(self._q, quat_from_rotvec(dx[:3]))
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        self._q = (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
        b = self._b
        self._b = (b[0] + dx[3], b[1] + dx[4], b[2] + dx[5])

    def _estimate(self) -> Estimate:
        assert self._q is not None
        x, y, z, w = self._q
        if w < 0.0:
            x, y, z, w = -x, -y, -z, -w
        k = 1.0 / (1.0 + w)
        g, b = self._gyro, self._b
        return Estimate(
            t_s=self._t,
            sigma_bn=np.array((x * k, y * k, z * k)),
            quat=np.array((x, y, z, w)),
            omega_b=np.array((g[0] - b[0], g[1] - b[1], g[2] - b[2])),
            bias_rad_s=np.array(b),
            covariance=self._p.copy(),
        )


def _inv_sym3(s: _Floats) -> _Floats:
    """Inverse of a symmetric 3 x 3 matrix (its upper triangle) by the adjugate: a third
    of ``np.linalg.inv``'s cost at this size."""
    (a, b, c), (_, d, e), (_, _, f) = s.tolist()
    m11, m12, m13 = d * f - e * e, c * e - b * f, b * e - c * d
    m22, m23, m33 = a * f - c * c, b * c - a * e, a * d - b * b
    i = 1.0 / (a * m11 + b * m12 + c * m13)
    return np.array(
        [[m11 * i, m12 * i, m13 * i], [m12 * i, m22 * i, m23 * i], [m13 * i, m23 * i, m33 * i]]
    )


def steady_state_covariance(
    cfg: MekfConfig, star_tracker_rate_hz: float, max_steps: int = 20_000
) -> _Floats:
    """The worst-phase steady-state covariance (6 x 6) of the filter at zero body rate.

    The covariance recursion alone, from the filter's initial covariance: propagate every
    ``cfg.dt_s``, update at the steps at which the tracker samples
    (:func:`attitude_core.models.sensor_spec.star_tracker_sample_steps`). With a zero rate the
    axes decouple into three 2-state problems and ``Qd`` composes exactly, so the
    propagation between two samples is done in one go. The sampling pattern repeats with
    a cycle of ``L`` samples (``3, 2`` steps at 4 Hz and 0.1 s); the recursion runs until
    the pre-update covariance at every phase of the cycle changes by less than 1e-9
    (relative) from one cycle to the next, or ``max_steps`` steps. Returns the largest
    (by attitude trace) pre-update covariance over the cycle: the uncertainty just before
    the sample that ends the longest gap. With no bias walk there is no steady state (the
    bias variance keeps falling): the result is then that after ``max_steps`` steps.
    """
    dt = cfg.dt_s
    steps = star_tracker_sample_steps(star_tracker_rate_hz, dt, max_steps + 1)
    gaps = np.diff(steps)
    if gaps.size == 0:  # fewer than two samples in max_steps: one gap of a whole period
        gaps = np.array([max(1, math.ceil(1.0 / (star_tracker_rate_hz * dt) - 1e-9))])
    cycle = 0
    for n in range(1, gaps.size // 2 + 1):
        if np.array_equal(gaps[n:], gaps[:-n]):
            cycle = n
            break
    periodic = cycle > 0
    if not periodic:  # no repeating pattern in max_steps: one pass over the whole sequence
        cycle = int(gaps.size)
    intervals = [float(g) * dt for g in gaps[:cycle]]
    steps_per_cycle = int(np.sum(gaps[:cycle]))
    max_cycles = max(2, max_steps // steps_per_cycle) if periodic else 1
    sv2 = cfg.arw_density
    su2 = cfg.gyro_bias_walk_rad_s2**2
    noises = [(t * sv2 + su2 * t**3 / 3.0, -su2 * t * t / 2.0, su2 * t) for t in intervals]
    prior2 = cfg.gyro_bias_prior_rad_s**2

    per_value: dict[float, list[tuple[float, float, float]]] = {}
    for r in cfg.star_tracker_noise_rad:
        r2 = float(r) ** 2
        if r2 not in per_value:
            per_value[r2] = _axis_cycle(r2, prior2, intervals, noises, max_cycles)
    axes = [per_value[float(r) ** 2] for r in cfg.star_tracker_noise_rad]
    first = cycle // 2 if not periodic else 0
    worst = max(range(first, cycle), key=lambda j: sum(axis[j][0] for axis in axes))
    p = np.zeros((6, 6))
    for i, axis in enumerate(axes):
        p11, p12, p22 = axis[worst]
        p[i, i], p[i, i + 3], p[i + 3, i], p[i + 3, i + 3] = p11, p12, p12, p22
    return p


def _axis_cycle(
    r2: float,
    prior2: float,
    intervals: list[float],
    noises: list[tuple[float, float, float]],
    max_cycles: int,
) -> list[tuple[float, float, float]]:
    """One axis's pre-update ``(p11, p12, p22)`` at each phase of the sampling cycle, at
    convergence (:func:`steady_state_covariance`). Plain floats; the cycles run in
    batches of about 50 samples, between which two consecutive cycles are compared."""
    phases = [
        (t, 2.0 * t, t * t, q11, q12, q22)
        for t, (q11, q12, q22) in zip(intervals, noises, strict=True)
    ]
    batch = max(1, 50 // len(phases))
    p11, p12, p22 = r2, 0.0, prior2  # the filter's initial covariance
    previous: list[tuple[float, float, float]] = []
    done = 0
    while True:
        current: list[tuple[float, float, float]] = []
        record = done % (batch + 1) >= batch - 1 or done >= max_cycles - 2
        for t, t2, tt, q11, q12, q22 in phases:
            p11 = p11 - t2 * p12 + tt * p22 + q11  # propagate, Phi = [[1, -t], [0, 1]]
            p12 = p12 - t * p22 + q12
            p22 = p22 + q22
            if record:
                current.append((p11, p12, p22))
            s = p11 + r2  # update, H = [1 0]
            k = r2 / s
            p22 = p22 - p12 * p12 / s
            p11 = p11 * k
            p12 = p12 * k
        done += 1
        if not record:
            previous = []
            continue
        if previous and all(
            abs(a11 - b11) <= 1e-9 * a11
            and abs(a22 - b22) <= 1e-9 * a22
            and abs(a12 - b12) <= 1e-9 * math.sqrt(a11 * a22)
            for (a11, a12, a22), (b11, b12, b22) in zip(current, previous, strict=True)
        ):
            return current
        if done >= max_cycles:
            return current
        previous = current


def nees(estimate: Estimate, sigma_bn_true: Vec3Like, bias_true: Vec3Like) -> float:
    """Normalised estimation error squared ``e^T P^-1 e`` over the 6 states, with
    ``e = [rotation vector of q_est^-1 (x) q_true (body axes), bias_true - bias_est]``."""
    q_true = quat_from_mrp(np.asarray(sigma_bn_true, dtype=float))
    e_att = rotvec_from_quat(quat_mul(quat_conj(estimate.quat), q_true))
    e = np.concatenate([e_att, np.asarray(bias_true, dtype=float) - estimate.bias_rad_s])
    return float(e @ np.linalg.solve(estimate.covariance, e))


def attitude_error_rad(sigma_est: Vec3Like, sigma_true: Vec3Like) -> float:
    """Principal angle (rad, ``[0, pi]``) of the rotation between the two attitudes."""
    return angle_between_single(sigma_est, sigma_true)
