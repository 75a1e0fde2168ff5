# Types of the compiled kernels (kernels/_kernels.pyx and its .pxi includes); see that
# module's docstring.
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

_Vec = Sequence[float] | npt.NDArray[np.float64]

def angle_between(sigma_a: _Vec, sigma_b: _Vec) -> float: ...
def relative(sigma_bn: _Vec, sigma_rn: _Vec) -> tuple[float, float, float]: ...
def pd_command(
    kp: tuple[float, ...],
    kd: tuple[float, ...],
    sigma_bn: _Vec,
    omega_b: _Vec,
    sigma_rn: _Vec,
    omega_r: _Vec,
    bound: Sequence[float] | None,
) -> tuple[float, float, float, bool]: ...
def rk4_step(
    inertia: tuple[float, ...],
    inertia_inv: tuple[float, ...],
    sigma_bn: _Vec,
    omega_b: _Vec,
    torque_b: _Vec,
    dt: float,
) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...

class LoopPlant:
    def __init__(
        self,
        kp: tuple[float, ...],
        kd: tuple[float, ...],
        bound: Sequence[float] | None,
        inertia: tuple[float, ...],
        inertia_inv: tuple[float, ...],
        dt: float,
        sigma: npt.NDArray[np.float64],
        omega: npt.NDArray[np.float64],
        torque: npt.NDArray[np.float64],
        sigma_t: npt.NDArray[np.float64],
        omega_t: npt.NDArray[np.float64],
    ) -> None: ...
    def step(
        self, k: int, sigma_m: _Vec, omega_m: _Vec, target_sigma: _Vec, target_omega: _Vec
    ) -> None: ...
    def hold(
        self,
        k: int,
        stop: int,
        goal: _Vec,
        target_sigma: _Vec,
        target_omega: _Vec,
        band_deg: float,
        band_rate: float,
    ) -> int: ...

def dense_interval_minima(
    kernel: ConeKernel,
    t: npt.NDArray[np.float64],
    q: npt.NDArray[np.float64],
    qd: npt.NDArray[np.float64],
    basis: npt.NDArray[np.float64],
    out: npt.NDArray[np.float64],
    slack: float,
) -> float: ...

class ConeKernel:
    def __init__(
        self,
        keep_out: npt.NDArray[np.float64],
        keep_in: npt.NDArray[np.float64],
        circles: npt.NDArray[np.float64],
        samples: int,
        rims: npt.NDArray[np.float64] | None = None,
        rim_dirs: npt.NDArray[np.float64] | None = None,
    ) -> None: ...
    def min_margin_deg(self, sigma_bn: _Vec) -> float: ...
    def arc_min_margin_deg(self, sigma_a: _Vec, sigma_b: _Vec) -> float: ...
    def closest_rim(self, sigma: _Vec) -> tuple[int, float, float, float, int, int]: ...
    def closest_obstacle(
        self, sigma: _Vec, inflation_deg: float
    ) -> tuple[float, tuple[float, float, float], tuple[float, float, float], int]: ...

class FisKernel:
    table: object
    def __init__(self, table: object) -> None: ...

class FepfState:
    sigma_t: tuple[float, float, float]
    goal: tuple[float, float, float]
    rate: tuple[float, float, float]
    omega_held: tuple[float, float, float]
    last_obstacle_direction: tuple[float, float, float]
    wanted_omega: tuple[float, float, float]
    status: Any
    checked: tuple[tuple[float, float, float], float] | None
    margin_at: tuple[float, float, float] | None
    arc_key: tuple[tuple[float, float, float], tuple[float, float, float]] | None
    final_goal: bool
    goal_in_sight: bool
    evade: bool
    beyond_mrp: float
    d_goal: float
    raw_speed: float
    last_obstacle_distance: float
    best_goal_distance: float
    since_progress: float
    margin: float
    arc: float
    def __init__(self) -> None: ...

class FepfCore:
    @property
    def state(self) -> FepfState: ...
    def __init__(
        self,
        state: FepfState,
        reference: object,
        cfg: object,
        gamma: float,
        cos_g: float,
        sin_g: float,
        relative: bool,
        paper_axis: bool,
        watchdog: bool,
        inputs_a: tuple[str, ...],
        inputs_r: tuple[str, ...],
        output_cls: type,
        statuses: tuple[object, object, object],
        rim_floor: float,
        sight_tol: float,
    ) -> None: ...
    def set_geometry(self, geometry: object) -> None: ...
    def set_tables(self, table_a: object, table_r: object) -> None: ...
    def propose(self, dt_since: float, dt_ahead: float) -> object: ...
    def hold_rate(self, rate: _Vec, dt_ahead: float) -> tuple[float, float, float]: ...
    def advance(self, dt: float) -> None: ...

class GuidanceState:
    t_prev: float | None
    omega_prev: npt.NDArray[np.float64]
    status: Any
    behind_since: float | None
    pending: Any
    follower: Any
    derating: float
    derated_at: float
    since_progress: float
    best_body: float
    best_target: float
    def __init__(self) -> None: ...

class GuidanceCore:
    @property
    def state(self) -> GuidanceState: ...
    def __init__(
        self,
        state: GuidanceState,
        fepf: FepfCore,
        guidance: object,
        statuses: tuple[object, object, object, object, object],
        output_cls: type,
        constants: tuple[float, float, float, float],
        hooks: tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]],
    ) -> None: ...
    def update(self, t_s: float, sigma_bn: _Vec, omega_b: _Vec) -> object: ...
