"""Fuzzy enhanced potential field (FEPF) guidance in MRP space (paper eqs. 6-10, 12).

At the current target ``sigma_t`` the planner outputs
``sigma_t_dot = m_a sigma_a_hat + m_r sigma_r_hat`` (eq. 6) with the attractive direction
``sigma_a_hat = (sigma_d - sigma) / |sigma_d - sigma|`` (eq. 7), the repulsive direction
``sigma_r_hat = -R(gamma, o_hat) sigma_c_hat`` (eqs. 8-9) and magnitudes ``m_a``, ``m_r``
from two fuzzy inference systems (:mod:`attitude_core.fsw.guidance.fuzzy`) whose inputs are scaled
to [0, 1]. ``sigma_t`` is integrated with an Euler step and ``omega_t`` follows from
eq. 12.

Rotation axis ``o_hat`` (eq. 10), two forms:

* ``"paper"``: ``o ~ sigma_c_hat x sigma`` as printed (normalised to unit length so that
  eq. 9 is a rotation; the printed form is not unit length).
* ``"goal_plane"`` (default): ``o ~ sigma_a_hat x sigma_c_hat``, the normal of the plane
  holding the goal and obstacle directions, so a positive ``gamma`` turns the
  repulsion from straight away towards the goal side of the obstacle.

EPF enhancement against the goal-non-reachable-with-obstacles-nearby trap: the
repulsive term fades out when the goal is closer than the closest obstacle (the
straight segment to the goal is then provably free), see :func:`_goal_occlusion`.

Planning frame (``planner.planning_frame``):

* ``"inertial"`` (paper variant): the law above in ``sigma_BN`` coordinates.
* ``"target"`` (improved variant): the same law in MRPs relative to the current target,
  re-anchored at every step. There ``sigma = 0``, the goal is ``sigma_D/T`` (the short
  way, ``|sigma_D/T| <= 1``) and the straight line to it is the short eigenaxis
  rotation, across ``|sigma_BN| = 1`` when that is shorter. Obstacle distance and
  direction are measured in ``sigma_BN`` and carried over by ``B(sigma)``, which is a
  rotation times ``1 + |sigma|^2`` (eq. 3), so directions keep their angles. The rate is
  mapped back as ``sigma_dot = B(sigma) rho_dot`` (``rho`` the relative MRP), so
  ``omega_t = 4 rho_dot`` (eq. 12 at ``rho = 0``). The repulsion also fades when the
  whole eigenaxis rotation to the goal is proven outside the buffered cones (the exact
  closed-form margin along it), the same enhancement as below with a sharper proof.

Intermediate goals: :meth:`FepfPlanner.set_goal` moves the goal (a global route's
waypoints); the capture, the terminal slow-down and the landing apply to the final goal
only.

Safety, beyond the paper: each step is no longer than 0.9 times the distance to the
closest (inflated) keep-out region, so the whole segment is provably outside it, and
the end point is re-checked with the exact margin. Improved variant only: a bounded
target acceleration and a terminal time constant that brings ``sigma_t_dot`` to zero at
the goal (the paper notes a non-zero terminal rate).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.fepf_state import FepfState
from attitude_core.fsw.guidance.fuzzy import MamdaniFis, load_fis, lookup_table
from attitude_core.fsw.guidance.fuzzy.files import resolve_fis
from attitude_core.fsw.guidance.fuzzy.table import FisTable
from attitude_core.fsw.guidance.planner_config import DirectionAxis, PlannerConfig, PlanningFrame
from attitude_core.fsw.guidance.state_field import StateField
from attitude_core.models.constraints import RIM_FLOOR, ConeGeometry
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    mrp_rate_single,
    omega_from_mrp_rate_single,
    relative_single,
)

__all__ = [
    "PlannerStatus",
    "PlannerOutput",
    "FepfPlanner",
    "load_planner_fis",
    "rotation_matrix",
]


@dataclass(slots=True)
class PlannerOutput:
    """Target for one step: ``sigma_t`` (MRP), ``sigma_t_dot`` (1/s), ``omega_t``
    (rad/s, target-frame axes), the status, the FIS magnitudes and the MRP-space
    distance to the closest inflated keep-out region."""

    sigma_t: np.ndarray
    sigma_t_dot: np.ndarray
    omega_t: np.ndarray
    status: PlannerStatus
    m_a: float
    m_r: float
    obstacle_distance_mrp: float


def rotation_matrix(gamma: float, axis: Vec3Like) -> npt.NDArray[np.float64]:
    """Eq. 9: rotation by ``gamma`` (rad) about the unit vector ``axis``."""
    o1, o2, o3 = axis
    c, s = math.cos(gamma), math.sin(gamma)
    k = 1.0 - c
    return np.array(
        [
            [o1 * o1 * k + c, o1 * o2 * k - o3 * s, o1 * o3 * k + o2 * s],
            [o2 * o1 * k + o3 * s, o2 * o2 * k + c, o2 * o3 * k - o1 * s],
            [o3 * o1 * k - o2 * s, o3 * o2 * k + o1 * s, o3 * o3 * k + c],
        ]
    )


def _rotate(v: Vec3, axis: Vec3, cos_g: float, sin_g: float) -> Vec3:
    """Rodrigues rotation of ``v`` about unit ``axis`` (same as ``rotation_matrix @ v``)."""
    vx, vy, vz = v
    ox, oy, oz = axis
    dot = ox * vx + oy * vy + oz * vz
    cx, cy, cz = oy * vz - oz * vy, oz * vx - ox * vz, ox * vy - oy * vx
    k = (1.0 - cos_g) * dot
    return (
        vx * cos_g + cx * sin_g + ox * k,
        vy * cos_g + cy * sin_g + oy * k,
        vz * cos_g + cz * sin_g + oz * k,
    )


def _unit_or_none(x: float, y: float, z: float, eps: float = 1e-9) -> Vec3 | None:
    n = math.sqrt(x * x + y * y + z * z)
    if n < eps:
        return None
    return (x / n, y / n, z / n)


def _any_perpendicular(v: Vec3) -> Vec3 | None:
    x, y, z = v
    if abs(x) < 0.9:
        return _unit_or_none(0.0, z, -y)  # v x e1
    return _unit_or_none(-z, 0.0, x)  # v x e2


def load_planner_fis(
    config: PlannerConfig, base_dir: str | os.PathLike[str] | None = None
) -> tuple[MamdaniFis, MamdaniFis]:
    """The attractive and repulsive FIS of ``config``: packaged names, or paths (a
    relative path is resolved against ``base_dir``, and refused without one)."""

    def load(name: str) -> MamdaniFis:
        if base_dir is None and "/" in name and not os.path.isabs(name):
            raise ValueError(f"FIS path {name!r} is relative: give the directory it is in")
        return load_fis(resolve_fis(name, "/" if base_dir is None else base_dir))

    return load(config.fis_attractive), load(config.fis_repulsive)


class FepfPlanner:
    """Stateful FEPF guidance: call :meth:`step` once per ``dt``.

    Parameters
    ----------
    geometry : keep-out geometry whose ``inflation_deg`` is the planner's safety buffer.
    sigma_0, sigma_goal : start and goal MRPs (``|sigma| <= 1``).
    dt_s : step, s.
    config : a :class:`attitude_core.config.scenario.PlannerConfig` (or any object with the
        same attributes).
    fis : the attractive and repulsive FIS (:func:`load_planner_fis`; default: loaded
        from ``config``'s packaged names or absolute paths).
    watchdog : whether the planner declares itself ``stuck`` when the target stops
        approaching the goal (off when a guidance layer judges progress on the body).

    Its mutable state is one record, :attr:`state` (a
    :class:`~attitude_core.fsw.guidance.fepf_state.FepfState`, compiled with the kernels);
    the attributes ``sigma_t``, ``status``, ``goal``, ``final_goal``, ``evade``,
    ``goal_in_sight``, ``wanted_omega`` and ``last_obstacle_distance`` / ``_direction``
    are its fields. The compiled step (``_kernels.FepfCore``) steps the same record; it is
    handed the geometry (:meth:`set_geometry`) and the FIS tables (:meth:`prepare`) when
    they change, and calls back this planner's ``*_reference`` methods and
    :meth:`prepare` as its documented hooks (``kernels/fepf.pxi``).
    """

    sigma_t = StateField[Vec3]()
    status = StateField[PlannerStatus]()
    goal = StateField[Vec3]()
    final_goal = StateField[bool]()  # False while the goal is a route's intermediate waypoint
    evade = StateField[bool]()  # a moving sky: a cone coming over a held target pushes it out
    goal_in_sight = StateField[bool]()  # the rotation to the goal keeps the buffer (target frame)
    wanted_omega = StateField[Vec3]()
    last_obstacle_distance = StateField[float]()
    last_obstacle_direction = StateField[Vec3]()

    def __init__(
        self,
        geometry: ConeGeometry,
        sigma_0: Vec3Like,
        sigma_goal: Vec3Like,
        dt_s: float,
        config: PlannerConfig,
        fis: tuple[MamdaniFis, MamdaniFis] | None = None,
        watchdog: bool = True,
    ) -> None:
        k = kernels.compiled
        self.state: FepfState = FepfState() if k is None else k.FepfState()
        self.geometry = geometry
        self.dt = float(dt_s)
        self.cfg = config
        self.goal = cast(Vec3, tuple(float(x) for x in sigma_goal))
        self.fis_a, self.fis_r = load_planner_fis(config) if fis is None else fis
        known = {"goal_distance", "obstacle_distance", "approach"}
        for one in (self.fis_a, self.fis_r):
            unknown = set(one.input_names) - known
            if unknown:
                raise ValueError(
                    f"FIS '{one.name}': unknown input(s) {sorted(unknown)}; "
                    f"the planner provides {sorted(known)}"
                )
        self._tables: tuple[FisTable, FisTable] | None = None  # built by prepare()
        self._inputs_a = tuple(self.fis_a.input_names)
        self._inputs_r = tuple(self.fis_r.input_names)
        self._gamma = math.radians(config.gamma_deg)
        self._cos_g, self._sin_g = math.cos(self._gamma), math.sin(self._gamma)
        self._paper_axis = config.direction_axis == DirectionAxis.PAPER
        self.relative = config.planning_frame == PlanningFrame.TARGET
        self.final_goal = True
        self.state.beyond_mrp = 0.0
        self.goal_in_sight = False
        self.watchdog = watchdog
        self.evade = False
        self.reset(sigma_0)
        # The compiled step on self.state (kernels.compiled.FepfCore), None: the Python
        # reference. Its configuration is handed over here, once.
        self._core: Any = (
            None
            if k is None
            else k.FepfCore(
                self.state,
                self,
                config,
                self._gamma,
                self._cos_g,
                self._sin_g,
                self.relative,
                self._paper_axis,
                watchdog,
                self._inputs_a,
                self._inputs_r,
                PlannerOutput,
                (PlannerStatus.TRACKING, PlannerStatus.ARRIVED, PlannerStatus.STUCK),
                RIM_FLOOR,
                _SIGHT_TOL_DEG,
            )
        )
        if self._core is not None:
            self._core.set_geometry(geometry)

    @property
    def compiled_core(self) -> Any:
        """The compiled step (``_kernels.FepfCore``) on :attr:`state`, or None when the
        Python reference steps it (a compiled guidance steps the planner through it)."""
        return self._core

    def hold(self, status: PlannerStatus) -> None:
        """End the target's motion with ``status`` (``infeasible``: it holds the start;
        ``stuck``: it holds where it is), as decided by a guidance layer."""
        self.status = status

    def prepare(self) -> None:
        """Build the FIS lookup tables now (once per process and definition, a few
        tenths of a second); the first moving proposal does it otherwise, so a slew
        declared infeasible before it never pays for them. The compiled step gets them
        here (its hook for them)."""
        if self._tables is None:
            self._tables = (lookup_table(self.fis_a), lookup_table(self.fis_r))
            if self._core is not None:
                self._core.set_tables(*self._tables)

    def set_goal(self, sigma_goal: Vec3Like, final: bool, beyond_mrp: float = 0.0) -> None:
        """Aim at ``sigma_goal`` from now on; ``final`` is False for a route's
        intermediate waypoint (no capture, no terminal slow-down, no landing there), and
        ``beyond_mrp`` the route's length after it, added to the FIS goal distance."""
        st = self.state
        st.goal = cast(Vec3, tuple(float(x) for x in sigma_goal))
        st.final_goal = bool(final)
        st.beyond_mrp = float(beyond_mrp)
        st.best_goal_distance = math.inf
        st.since_progress = 0.0

    def reset(self, sigma: Vec3Like) -> None:
        """Restart from attitude ``sigma`` (e.g. the measured attitude after a restart)."""
        st = self.state
        st.sigma_t = cast(Vec3, tuple(float(x) for x in sigma))
        st.rate = (0.0, 0.0, 0.0)
        st.status = PlannerStatus.TRACKING
        st.best_goal_distance = math.inf
        st.since_progress = 0.0
        st.last_obstacle_distance = math.nan
        st.last_obstacle_direction = (0.0, 0.0, 0.0)
        st.d_goal = math.inf
        st.raw_speed = 0.0
        st.omega_held = (0.0, 0.0, 0.0)  # body rate of the held rate where it was set
        st.margin_at = None  # the target position st.margin belongs to
        st.margin = math.nan
        st.arc_key = None  # (target, end) of st.arc
        st.arc = math.nan
        st.wanted_omega = (0.0, 0.0, 0.0)
        st.checked = None

    def set_geometry(self, geometry: ConeGeometry) -> None:
        """Plan on ``geometry`` from now on (a moving sky's cones over the next window;
        same buffer)."""
        self.geometry = geometry
        st = self.state
        st.margin_at = None
        st.arc_key = None
        st.checked = None
        if self._core is not None:
            self._core.set_geometry(geometry)

    # ------------------------------------------------------------------------------

    def step(self) -> PlannerOutput:
        """Return the target for the current step, then advance ``sigma_t`` by ``dt``."""
        out = self.propose(self.dt, self.dt)
        self.advance(self.dt)
        return out

    def propose(self, dt_since: float, dt_ahead: float) -> PlannerOutput:
        """The target at the current ``sigma_t`` and the rate to hold from now on.

        ``dt_since`` is the time since the previous proposal (it bounds the rate change,
        improved variant), ``dt_ahead`` the expected time to the next one (it bounds the
        step, see the module docstring). Nothing moves until :meth:`advance`. Compiled
        when the kernels are (:meth:`propose_reference`, to the bit).
        """
        if self._core is not None:
            out: PlannerOutput = self._core.propose(dt_since, dt_ahead)
            return out
        return self.propose_reference(dt_since, dt_ahead)

    def propose_reference(self, dt_since: float, dt_ahead: float) -> PlannerOutput:
        """:meth:`propose` in Python."""
        st = self.state
        sigma = st.sigma_t
        sx, sy, sz = sigma
        cfg = self.cfg
        if self.relative:
            ex, ey, ez = relative_single(st.goal, sigma)  # sigma_D/T, short way
            scale = 1.0 + sx * sx + sy * sy + sz * sz  # |B(sigma) x| / |x| (eq. 3)
        else:
            gx, gy, gz = st.goal
            ex, ey, ez = gx - sx, gy - sy, gz - sz
            scale = 1.0
        d_goal = math.sqrt(ex * ex + ey * ey + ez * ez)
        st.d_goal = d_goal
        if st.status == PlannerStatus.ARRIVED or (
            st.status == PlannerStatus.TRACKING
            and st.final_goal
            and d_goal <= cfg.goal_tolerance_mrp
        ):
            st.status = PlannerStatus.ARRIVED
            st.sigma_t = st.goal
            return self._hold_output(st.goal)
        if st.status != PlannerStatus.TRACKING:  # stuck or infeasible: hold
            return self._hold_output(sigma)
        if d_goal == 0.0 and not (st.evade and self.margin_deg() < self.geometry.inflation_deg):
            # On an intermediate goal: hold until the next one is set (on a moving sky,
            # unless a cone has come over it: then the repulsion pushes it out).
            return self._hold_output(sigma)

        a_hat = (ex / d_goal, ey / d_goal, ez / d_goal) if d_goal > 0.0 else (0.0, 0.0, 0.0)
        d_obs, c_hat, _, _ = self.geometry.closest_obstacle_single(sigma)
        st.last_obstacle_distance = d_obs
        st.last_obstacle_direction = c_hat
        if self.relative:
            c_hat = _to_target_frame(sigma, c_hat, scale)
            d_obs = d_obs / scale
        ac = a_hat[0] * c_hat[0] + a_hat[1] * c_hat[1] + a_hat[2] * c_hat[2]
        visibility = _goal_occlusion(d_goal, d_obs)
        st.goal_in_sight = False
        if self.relative and d_goal > 0.0:  # (d_goal 0: a held target pushed out)
            if d_obs < cfg.influence_distance_mrp:
                arc = self.arc_margin_deg(st.goal)
                st.goal_in_sight = arc >= self.sight_margin_deg()
            else:
                st.goal_in_sight = visibility == 0.0
            if st.goal_in_sight:
                visibility = 0.0
        obstacle_input = min(max(d_obs / cfg.influence_distance_mrp, 0.0), 1.0)
        inputs = {
            "goal_distance": min(scale * (d_goal + st.beyond_mrp), 1.0),
            # The rotation to the goal is proven free: no obstacle lies on the way.
            "obstacle_distance": 1.0 if st.goal_in_sight else obstacle_input,
            "approach": 0.5 * (1.0 + ac),
        }
        if self._tables is None:
            self.prepare()
        table_a, table_r = cast(tuple[FisTable, FisTable], self._tables)
        m_a = cfg.max_attractive_rate_mrp_s * table_a(*(inputs[n] for n in self._inputs_a))
        m_r = 0.0
        if d_obs < cfg.influence_distance_mrp and visibility > 0.0:
            inputs["obstacle_distance"] = obstacle_input
            m_r = (
                visibility
                * cfg.max_repulsive_rate_mrp_s
                * table_r(*(inputs[n] for n in self._inputs_r))
            )

        vx, vy, vz = m_a * a_hat[0], m_a * a_hat[1], m_a * a_hat[2]
        if m_r > 0.0:
            r_hat = self._repulsive_direction(a_hat, c_hat, ac)
            vx, vy, vz = vx + m_r * r_hat[0], vy + m_r * r_hat[1], vz + m_r * r_hat[2]
        # The rate the law asks for before shaping, as a body rate (target axes).
        if self.relative:
            st.wanted_omega = (4.0 * vx, 4.0 * vy, 4.0 * vz)
        else:
            w = omega_from_mrp_rate_single(sigma, (vx, vy, vz))
            st.wanted_omega = (float(w[0]), float(w[1]), float(w[2]))
        vx, vy, vz = self._shape_rate(vx, vy, vz, d_goal, dt_since, scale)
        if self.relative:  # back to sigma_BN rates: sigma_dot = B(sigma) rho_dot
            vx, vy, vz = mrp_rate_single(sigma, (4.0 * vx, 4.0 * vy, 4.0 * vz))
        st.raw_speed = math.sqrt(vx * vx + vy * vy + vz * vz) / scale
        (vx, vy, vz), _ = self._safe_step((vx, vy, vz), dt_ahead)
        rate = (vx, vy, vz)
        st.rate = rate
        st.omega_held = self._body_rate(rate)
        st.checked = (rate, dt_ahead)
        return self._output(sigma, rate, m_a, m_r, d_obs)

    def _hold_output(self, sigma: Vec3) -> PlannerOutput:
        """The target held at ``sigma``: no rate, none held, nothing checked."""
        st = self.state
        st.rate = (0.0, 0.0, 0.0)
        st.omega_held = (0.0, 0.0, 0.0)
        st.checked = None
        return self._output(sigma, (0.0, 0.0, 0.0), 0.0, 0.0, st.last_obstacle_distance)

    @property
    def goal_distance_mrp(self) -> float:
        """MRP distance from the target to the goal at the last proposal, in the planning
        frame, plus the route's length beyond an intermediate goal (:meth:`set_goal`)."""
        return self.state.d_goal + self.state.beyond_mrp

    @property
    def rate(self) -> Vec3:
        """The MRP rate held from the last proposal, 1/s."""
        return self.state.rate

    def hold_rate(self, rate: Vec3Like, dt_ahead: float) -> Vec3:
        """Replace the rate held until the next proposal (a guidance layer's shaping) and
        return it made safe for a step of ``dt_ahead`` (the rate the target will move
        with, so the one to publish); :meth:`advance` checks a longer step again.
        Compiled when the kernels are (:meth:`hold_rate_reference`)."""
        if self._core is not None:
            held: Vec3 = self._core.hold_rate(rate, dt_ahead)
            return held
        return self.hold_rate_reference(rate, dt_ahead)

    def hold_rate_reference(self, rate: Vec3Like, dt_ahead: float) -> Vec3:
        """:meth:`hold_rate` in Python."""
        st = self.state
        safe, _ = self._safe_step(cast(Vec3, tuple(float(x) for x in rate)), dt_ahead)
        st.rate = safe
        st.omega_held = self._body_rate(safe)
        st.checked = (safe, dt_ahead)
        return safe

    def _step_keeps_margin(self, rate: Vec3, dt: float) -> bool:
        """Whether the step along ``rate`` for ``dt`` keeps, all along, the buffer or the
        target's own margin if lower (closed form over the eigenaxis rotation between
        the step's ends, which the straight MRP step follows to second order)."""
        s = self.state.sigma_t
        end = (s[0] + rate[0] * dt, s[1] + rate[1] * dt, s[2] + rate[2] * dt)
        need = min(self.geometry.inflation_deg, self.margin_deg())
        return self.geometry.arc_min_margin_deg_single(s, end) >= need

    def margin_deg(self) -> float:
        """The exact smallest margin (eq. 5) at the target, deg; computed once per target
        position (the law, its step check and the guidance all ask for it)."""
        st = self.state
        if st.margin_at != st.sigma_t:
            st.margin = self.geometry.min_margin_deg_single(st.sigma_t)
            st.margin_at = st.sigma_t
        return st.margin

    def arc_margin_deg(self, to: Vec3Like) -> float:
        """The exact smallest margin along the short rotation from the target to ``to``,
        deg (closed form); the last one is kept (the guidance and the law ask for the
        rotation to the same goal in one step)."""
        st = self.state
        key = (st.sigma_t, (float(to[0]), float(to[1]), float(to[2])))
        if st.arc_key != key:
            st.arc = self.geometry.arc_min_margin_deg_single(*key)
            st.arc_key = key
        return st.arc

    def sight_margin_deg(self) -> float:
        """The margin a rotation to the goal must keep all along to count as free: the
        buffer; from a target at or inside the buffer's rim (pushed there, or a
        restart), :data:`attitude_core.models.constraints.RIM_FLOOR` of it or the target's
        own margin if lower, as the route from there keeps."""
        buffer = self.geometry.inflation_deg
        here = self.margin_deg()
        return buffer if here >= buffer else min(RIM_FLOOR * buffer, here) - _SIGHT_TOL_DEG

    def _body_rate(self, rate: Vec3) -> Vec3:
        w = omega_from_mrp_rate_single(self.state.sigma_t, rate)
        return (float(w[0]), float(w[1]), float(w[2]))

    def advance(self, dt: float) -> None:
        """Move ``sigma_t`` along the held rate for ``dt`` s (the time to the next state).

        The step is kept safe as in the proposal; a step the proposal already checked
        (same rate, no longer) is taken as is. Compiled when the kernels are
        (:meth:`advance_reference`).
        """
        if self._core is not None:
            self._core.advance(dt)
        else:
            self.advance_reference(dt)

    def advance_reference(self, dt: float) -> None:
        """:meth:`advance` in Python."""
        st = self.state
        if st.status != PlannerStatus.TRACKING or dt <= 0.0:
            return
        rate = st.rate
        checked = st.checked
        s0 = st.sigma_t
        scale = 1.0 + s0[0] ** 2 + s0[1] ** 2 + s0[2] ** 2 if self.relative else 1.0
        speed = math.sqrt(rate[0] ** 2 + rate[1] ** 2 + rate[2] ** 2) / scale  # planning frame
        if checked is not None and checked[0] == rate and dt <= checked[1]:
            speed = st.raw_speed  # the terminal rule sees the step before the shortening
            new = (s0[0] + rate[0] * dt, s0[1] + rate[1] * dt, s0[2] + rate[2] * dt)
        else:
            rate, new = self._safe_step(rate, dt)
            st.rate = rate
            st.omega_held = self._body_rate(rate)
        # Terminal step: land exactly on the goal when the step would reach it.
        d_goal = st.d_goal
        if st.final_goal:
            if self.relative:
                nx, ny, nz = relative_single(st.goal, new)
            else:
                gx, gy, gz = st.goal
                nx, ny, nz = gx - new[0], gy - new[1], gz - new[2]
            step_len = dt * speed
            if nx * nx + ny * ny + nz * nz <= self.cfg.goal_tolerance_mrp**2 or (
                self.cfg.terminal_time_constant_s == 0.0
                and step_len >= d_goal
                and d_goal < st.last_obstacle_distance
            ):
                new = st.goal
        self._advance(new, d_goal, dt)

    def _safe_step(self, rate: Vec3, dt: float) -> tuple[Vec3, Vec3]:
        """``(rate, end point)``: the rate shortened so that the step of ``dt`` stays
        inside the obstacle-free ball around ``sigma_t``. Inside the widened buffer (a
        restart from a measured attitude can land there) there is no such ball: then a
        step is accepted only if it does not reduce the margin. In the target frame a
        step longer than the ball is also taken whole when its exact margin all along
        keeps the buffer, or the target's own margin if lower
        (:meth:`_step_keeps_margin`): a target grazing a buffered cone is not pinned to
        it by ever shorter steps."""
        sigma = self.state.sigma_t
        sx, sy, sz = sigma
        vx, vy, vz = rate
        d_obs = self.state.last_obstacle_distance
        step_len = dt * math.sqrt(vx * vx + vy * vy + vz * vz)
        floor = 0.5 * self.geometry.inflation_deg
        if d_obs > 0.0:
            limit = 0.9 * d_obs
            if step_len > limit and not (self.relative and self._step_keeps_margin(rate, dt)):
                f = limit / step_len
                vx, vy, vz = vx * f, vy * f, vz * f
        else:
            floor = min(floor, self.margin_deg())
        new = (sx + vx * dt, sy + vy * dt, sz + vz * dt)
        for _ in range(6):
            if self.geometry.min_margin_deg_single(new) >= floor:
                break
            vx, vy, vz = 0.5 * vx, 0.5 * vy, 0.5 * vz
            new = (sx + vx * dt, sy + vy * dt, sz + vz * dt)
        else:
            vx = vy = vz = 0.0
            new = sigma
        return (vx, vy, vz), new

    # ------------------------------------------------------------------------------

    def _repulsive_direction(self, a_hat: Vec3, c_hat: Vec3, ac: float) -> Vec3:
        """Eqs. 8-10: ``sigma_r_hat = -R(gamma, o_hat) sigma_c_hat``."""
        neg_c = (-c_hat[0], -c_hat[1], -c_hat[2])
        if self._gamma == 0.0:
            return neg_c
        if self._paper_axis:
            sx, sy, sz = self.state.sigma_t
            axis = _unit_or_none(
                c_hat[1] * sz - c_hat[2] * sy,
                c_hat[2] * sx - c_hat[0] * sz,
                c_hat[0] * sy - c_hat[1] * sx,
            )
            if axis is None:
                return neg_c
        else:
            axis = _unit_or_none(
                a_hat[1] * c_hat[2] - a_hat[2] * c_hat[1],
                a_hat[2] * c_hat[0] - a_hat[0] * c_hat[2],
                a_hat[0] * c_hat[1] - a_hat[1] * c_hat[0],
            )
            if axis is None:
                if ac < 0.0:  # obstacle straight behind: nothing to steer around
                    return neg_c
                # head-on: break the symmetry (not None: c_hat is a unit vector)
                axis = cast(Vec3, _any_perpendicular(c_hat))
        return _rotate(neg_c, axis, self._cos_g, self._sin_g)

    def _shape_rate(
        self, vx: float, vy: float, vz: float, d_goal: float, dt: float, scale: float = 1.0
    ) -> Vec3:
        """Improved variant: bounded target acceleration and terminal slow-down (in the
        planning frame; ``scale`` is ``1 + |sigma|^2`` in the target frame)."""
        cfg = self.cfg
        st = self.state
        a_max = cfg.max_accel_mrp_s2
        if a_max > 0.0:
            px, py, pz = st.rate
            if self.relative:  # the held rate in the target frame: omega / 4 (eq. 12, rho = 0)
                w = st.omega_held
                px, py, pz = 0.25 * w[0], 0.25 * w[1], 0.25 * w[2]
            dx, dy, dz = vx - px, vy - py, vz - pz
            dv = math.sqrt(dx * dx + dy * dy + dz * dz)
            dv_max = a_max * dt
            if dv > dv_max:
                f = dv_max / dv
                vx, vy, vz = px + dx * f, py + dy * f, pz + dz * f
        tau = cfg.terminal_time_constant_s
        if tau > 0.0 and st.final_goal:
            speed = math.sqrt(vx * vx + vy * vy + vz * vz)
            cap = d_goal / tau
            if speed > cap:
                f = cap / speed
                vx, vy, vz = vx * f, vy * f, vz * f
        return vx, vy, vz

    def _advance(self, new: Vec3, d_goal_before: float, dt: float) -> None:
        st = self.state
        st.sigma_t = new
        # Shadow switch keeps the target inside the unit ball (eq. 2).
        s2 = new[0] ** 2 + new[1] ** 2 + new[2] ** 2
        if s2 > 1.0:
            st.sigma_t = (-new[0] / s2, -new[1] / s2, -new[2] / s2)
            # d/dt(-s / s.s) = -s_dot / s.s + 2 (s . s_dot) s / (s.s)^2
            r = st.rate
            sr = new[0] * r[0] + new[1] * r[1] + new[2] * r[2]
            st.rate = cast(
                Vec3, tuple(-r[i] / s2 + 2.0 * sr * new[i] / (s2 * s2) for i in range(3))
            )
        # Stuck watchdog: no new best distance to the goal for stuck_timeout_s.
        if not self.watchdog:
            return
        if d_goal_before < st.best_goal_distance - 1e-6:
            st.best_goal_distance = d_goal_before
            st.since_progress = 0.0
        else:
            st.since_progress += dt
            if st.since_progress >= self.cfg.stuck_timeout_s:
                st.status = PlannerStatus.STUCK

    def _output(
        self, sigma: Vec3, rate: Vec3, m_a: float, m_r: float, d_obs: float
    ) -> PlannerOutput:
        return PlannerOutput(
            np.array(sigma, dtype=float),
            np.array(rate, dtype=float),
            omega_from_mrp_rate_single(sigma, rate),
            self.state.status,
            float(m_a),
            float(m_r),
            float(d_obs),
        )


_SIGHT_TOL_DEG = 1e-6  # a rotation leaving an attitude starts at that attitude's margin


def _to_target_frame(sigma: Vec3, v: Vec3, scale: float) -> Vec3:
    """A unit ``sigma_BN``-space direction at ``sigma`` in the target frame:
    ``B(sigma)^T v / (1 + |sigma|^2)`` (``B / (1 + |sigma|^2)`` is a rotation)."""
    s1, s2, s3 = sigma
    v1, v2, v3 = v
    a = 1.0 - (s1 * s1 + s2 * s2 + s3 * s3)
    sv = s1 * v1 + s2 * v2 + s3 * v3
    return (
        (a * v1 - 2.0 * (s2 * v3 - s3 * v2) + 2.0 * s1 * sv) / scale,
        (a * v2 - 2.0 * (s3 * v1 - s1 * v3) + 2.0 * s2 * sv) / scale,
        (a * v3 - 2.0 * (s1 * v2 - s2 * v1) + 2.0 * s3 * sv) / scale,
    )


def _goal_occlusion(d_goal: float, d_obs: float) -> float:
    """Weight of the repulsive term: 0 when the goal is closer than every obstacle.

    If ``d_goal <= d_obs`` the straight segment to the goal lies inside the
    obstacle-free ball around ``sigma``, so repulsion can only stop the target short of
    the goal (the "goal non-reachable with obstacles nearby" trap the EPF removes).
    The weight ramps linearly to 1 at ``d_goal = 2 d_obs`` to stay continuous.
    """
    if d_obs <= 0.0:
        return 1.0
    return min(max(d_goal / d_obs - 1.0, 0.0), 1.0)
