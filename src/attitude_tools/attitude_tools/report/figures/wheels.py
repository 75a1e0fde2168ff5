"""The reaction wheel figure (in: the figure context; out: a ``Figure``): for runs flown by
a wheel array (``RunResult.wheels``), each wheel's speed (rpm, relative to the body) and
the motor torque it applied (N m) against its limits (dashed, +/-), and the change of the
inertial system momentum ``C_BN^T H_B`` since the start
(:func:`attitude_core.record.wheel_figures.inertial_momentum`): flat at zero without
external torque, drifting by the integral of a disturbance such as the gravity gradient.

One column of three panels per wheel run (one column when one run has wheels). Artists
carry ``gid`` ``<run label>/wheel/<name>/<part>`` (``speed``, ``speed_limit``,
``torque``, ``torque_limit``, ``fails``) and ``<run label>/momentum/<i>`` (``i`` = 0, 1,
2: the change of the inertial components), so a test can find them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from attitude_core.models.wheel_array import RPM
from attitude_core.record.wheel_figures import inertial_momentum, wheel_figures

from ..data import ReportRun
from .catalog import flies_on_wheels
from .context import FigureContext, Floats
from .histories import arrival_lines, fault_spans
from .style import COMPONENT_COLORS, WHEEL_COLORS

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["fig_wheels", "momentum_change"]

LIMIT_LINE: dict[str, Any] = dict(linestyle=(0, (5, 3)), linewidth=1.1)
SHARED_LIMIT_COLOR = "0.3"  # a limit every wheel of the run shares: drawn grey
MOMENTUM_FLOOR = 0.01
"""The momentum panel spans at least +/- this fraction of the system momentum's size
(|H| at the start, or the change's own size if larger): a momentum constant to rounding
shows as flat lines at zero, not as magnified rounding noise."""


def momentum_change(run: ReportRun) -> tuple[Floats, Floats]:
    """(change of ``C_BN^T H_B`` since the first row ``(N + 1, 3)``, N m s; the first row)."""
    h_n = inertial_momentum(run.run)
    return h_n - h_n[0], h_n[0]


def _limit(ax: Axes, value: float, color: str, gid: str) -> None:
    for sign in (1.0, -1.0):
        ax.axhline(sign * value, color=color, gid=gid, **LIMIT_LINE)


def _momentum_ylim(ax: Axes, change: Floats, start: Floats) -> None:
    lo, hi = float(np.nanmin(change)), float(np.nanmax(change))
    scale = max(float(np.linalg.norm(start)), float(np.nanmax(np.abs(change))))
    half = max(0.55 * (hi - lo), MOMENTUM_FLOOR * scale, 1e-9)
    mid = 0.5 * (lo + hi)
    ax.set_ylim(mid - half, mid + half)


def _column(
    ctx: FigureContext, run: ReportRun, axes: tuple[Axes, Axes, Axes], color_of: dict[str, str]
) -> list[Artist]:
    """Draw one run's three panels; its legend handles of wheel failures."""
    ax_s, ax_u, ax_h = axes
    array, wheels = run.scenario.wheels, run.run.wheels
    assert array is not None and wheels is not None
    t = run.run.t
    shared_speed = bool(np.all(array.max_speed == array.max_speed[0]))
    shared_torque = bool(np.all(array.max_torque == array.max_torque[0]))
    fails: list[Artist] = []
    for i, spec in enumerate(array.wheels):
        name, color = spec.name, color_of[spec.name]
        gid = f"{run.label}/wheel/{name}"
        ax_s.plot(t, wheels.speed_rad_s[:, i] / RPM, color=color, linewidth=1.5, gid=f"{gid}/speed")
        ax_u.plot(
            t,
            wheels.applied_nm[:, i],
            color=color,
            linewidth=1.3,
            drawstyle="steps-post",  # held over [t_k, t_k+1)
            gid=f"{gid}/torque",
        )
        speed_color = SHARED_LIMIT_COLOR if shared_speed else color
        torque_color = SHARED_LIMIT_COLOR if shared_torque else color
        _limit(ax_s, float(array.max_speed[i]) / RPM, speed_color, f"{gid}/speed_limit")
        _limit(ax_u, float(array.max_torque[i]), torque_color, f"{gid}/torque_limit")
        if spec.fails_at_s is not None and spec.fails_at_s <= float(t[-1]):
            for ax in (ax_s, ax_u):
                ax.axvline(spec.fails_at_s, color=color, linestyle="-.", gid=f"{gid}/fails")
            fails.append(
                Line2D(
                    [],
                    [],
                    color=color,
                    linestyle="-.",
                    label=f"{name} fails ({spec.fails_at_s:g} s)",
                )
            )
    change, start = momentum_change(run)
    for i in range(3):
        ax_h.plot(
            t,
            change[:, i],
            color=COMPONENT_COLORS[i],
            linewidth=1.5,
            gid=f"{run.label}/momentum/{i}",
        )
    _momentum_ylim(ax_h, change, start)
    numbers = wheel_figures(run.run)
    prefix = f"{run.label}\n" if ctx.compare else ""
    ax_s.set_title(f"{prefix}peak |speed| / limit {numbers['peak_wheel_speed_frac']:.3g}")
    ax_u.set_title(f"peak |torque| / limit {numbers['peak_wheel_torque_frac']:.3g}")
    ax_h.set_title(
        f"|H(0)| {float(np.linalg.norm(start)):.4g} N m s; unexplained change "
        f"{numbers['momentum_error_nms']:.2g} N m s"
    )
    return fails


def fig_wheels(ctx: FigureContext) -> Figure:
    runs = [r for r in ctx.runs if flies_on_wheels(r)]
    names: list[str] = []
    for r in runs:
        assert r.scenario.wheels is not None
        names += [n for n in r.scenario.wheels.names if n not in names]
    color_of = {n: WHEEL_COLORS[k % len(WHEEL_COLORS)] for k, n in enumerate(names)}
    compare = len(runs) > 1
    fig, grid = plt.subplots(
        3,
        len(runs),
        figsize=(9.0 if not compare else 13.0, 9.0),
        sharex=True,
        height_ratios=(1.0, 1.0, 0.9),
        squeeze=False,
    )
    fails: list[Artist] = []
    for j, run in enumerate(runs):
        column = (grid[0, j], grid[1, j], grid[2, j])
        fails += _column(ctx, run, column, color_of)
        if j > 0:  # the same scale for both runs' speeds and torques
            grid[0, j].sharey(grid[0, 0])
            grid[1, j].sharey(grid[1, 0])
        grid[2, j].set_xlabel("time (s)")
    grid[0, 0].set_ylabel("wheel speed (rpm)")
    grid[1, 0].set_ylabel("motor torque\napplied (N m)")
    grid[2, 0].set_ylabel("change of\n$C_{BN}^T H_B$ (N m s)")
    axes = list(grid.flat)
    handles: list[Artist] = [
        Line2D([], [], color=color_of[n], linewidth=1.5, label=n) for n in names
    ]
    handles.append(
        Line2D([], [], color=SHARED_LIMIT_COLOR, label="limit +/- (dashed)", **LIMIT_LINE)
    )
    handles += fails + arrival_lines(ctx, axes) + fault_spans(ctx, axes)
    momentum = [
        Line2D(
            [],
            [],
            color=COMPONENT_COLORS[i],
            linewidth=1.5,
            label=f"$\\Delta H_{i + 1}$ (inertial)",
        )
        for i in range(3)
    ]
    if not compare:
        grid[0, 0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        grid[2, 0].legend(handles=momentum, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    else:
        fig.legend(
            handles=handles + momentum, loc="outside lower center", ncol=min(len(handles) + 3, 5)
        )
    fig.suptitle(f"{ctx.title}: reaction wheels")
    return fig
