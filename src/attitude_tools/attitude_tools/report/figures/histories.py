"""Time-history figures (in: the figure context; out: a ``Figure``): MRP, angular
velocity and control torque components and norms, with actuator limits and arrival
times; :func:`arrival_lines` marks the arrival, and the run's faults (``summary.json``
``faults``: a lost state, a tracker outage, safe mode) as shaded spans, on any time
axes."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from attitude_core.models.mrp import Vec3
from attitude_core.record.metrics import arrival_time

from ..data import ReportRun
from .context import FigureContext, Floats
from .style import COMPONENT_COLORS, RUN_COLORS

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = [
    "arrival_lines",
    "fault_spans",
    "fig_history_mrp",
    "fig_history_rate",
    "fig_history_torque",
]

FAULT_COLORS = {
    "state_lost": "tab:orange",
    "star_tracker_outage": "tab:purple",
    "safe_mode": "tab:red",
}
"""The shade of each fault kind (:class:`attitude_core.contract.faults.FaultKind`)."""


def fault_spans(ctx: FigureContext, axes: Iterable[Axes]) -> list[Artist]:
    """Each fault of each run shaded from its start to its end (the run's last time if
    it never ended), ``gid`` ``fault/<kind>/<k>``; one legend handle per kind shown."""
    from matplotlib.patches import Patch

    shown: dict[str, Artist] = {}
    axes = list(axes)
    for run in ctx.runs:
        t_last = float(run.run.t[-1]) if len(run.run.t) else 0.0
        for k, fault in enumerate(run.summary.get("faults") or []):
            kind = str(fault["kind"])
            color = FAULT_COLORS.get(kind, "0.5")
            end = fault["t_end_s"] if fault["t_end_s"] is not None else t_last
            for ax in axes:
                ax.axvspan(
                    fault["t_start_s"], end, color=color, alpha=0.15, linewidth=0,
                    gid=f"fault/{kind}/{k}",
                )  # fmt: skip
            shown.setdefault(kind, Patch(color=color, alpha=0.3, label=kind.replace("_", " ")))
    return list(shown.values())


def arrival_lines(ctx: FigureContext, axes: Iterable[Axes]) -> list[Artist]:
    handles: list[Artist] = []
    for k, run in enumerate(ctx.runs):
        t_reach = run.summary.get("t_reach_s")
        if t_reach is None:
            continue
        color = ctx.run_color(k, "0.3")
        for ax in axes:
            ax.axvline(t_reach, color=color, linestyle=":", linewidth=1.2)
        handles.append(
            Line2D(
                [],
                [],
                color=color,
                linestyle=":",
                label=f"arrival{' ' + run.label if ctx.compare else ''} ({t_reach:g} s)",
            )
        )
    return handles


def _history(
    ctx: FigureContext,
    name: str,
    symbol: str,
    unit: str,
    get: Callable[[ReportRun], Floats],
    norm_label: str,
    norm: Callable[[ReportRun], Floats] | None = None,
    target: Callable[[ReportRun], Floats] | None = None,
    target_label: str = "",
    bounds: Callable[[ReportRun], tuple[Vec3 | None, float | None]] | None = None,
) -> Figure:
    """Components (and a norm-like panel): one panel in single mode, one per component
    when comparing runs. ``bounds(run)`` gives ``(per-component bound or None, norm
    bound or None)``, drawn as dotted lines (the actuator limits)."""
    unit_txt = f" ({unit})" if unit else ""
    if not ctx.compare:
        fig, (ax, axn) = plt.subplots(
            2, 1, figsize=(9.0, 6.6), sharex=True, height_ratios=(1.6, 1.0)
        )
        run = ctx.runs[0]
        data = get(run)
        handles: list[Artist] = []
        for i in range(3):
            ax.plot(run.run.t, data[:, i], color=COMPONENT_COLORS[i], linewidth=1.6)
            handles.append(
                Line2D(
                    [], [], color=COMPONENT_COLORS[i], linewidth=1.6, label=f"{symbol}$_{i + 1}$"
                )
            )
            if target is not None:
                ax.plot(
                    run.run.t,
                    target(run)[:, i],
                    color=COMPONENT_COLORS[i],
                    linestyle=(0, (4, 3)),
                    linewidth=1.1,
                    gapcolor="white",
                )
        if target is not None:
            handles.append(Line2D([], [], color="0.3", linestyle="--", label=target_label))
        ax.set_ylabel(f"{symbol}{unit_txt}")
        values = norm(run) if norm is not None else np.linalg.norm(data, axis=1)
        axn.plot(run.run.t, values, color="black", linewidth=1.5)
        axn.set_ylabel(norm_label)
        per_axis, on_norm = bounds(run) if bounds is not None else (None, None)
        if per_axis is not None:
            for i in range(3):
                for sign in (-1.0, 1.0):
                    ax.axhline(sign * per_axis[i], color=COMPONENT_COLORS[i], linestyle=":")
        if on_norm is not None:
            axn.axhline(on_norm, color="black", linestyle=":")
        if per_axis is not None or on_norm is not None:
            handles.append(Line2D([], [], color="0.3", linestyle=":", label="actuator limit"))
        handles += arrival_lines(ctx, (ax, axn)) + fault_spans(ctx, (ax, axn))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        axn.set_xlabel("time (s)")
        axes = (ax, axn)
    else:
        fig, axes = plt.subplots(4, 1, figsize=(9.0, 9.0), sharex=True)
        for k, run in enumerate(ctx.runs):
            color = RUN_COLORS[k]
            data = get(run)
            for i in range(3):
                axes[i].plot(run.run.t, data[:, i], color=color, linewidth=1.5)
                if target is not None:
                    axes[i].plot(
                        run.run.t,
                        target(run)[:, i],
                        color=color,
                        linestyle=(0, (4, 3)),
                        linewidth=1.0,
                        gapcolor="white",
                    )
            values = norm(run) if norm is not None else np.linalg.norm(data, axis=1)
            axes[3].plot(run.run.t, values, color=color, linewidth=1.5)
        for i in range(3):
            axes[i].set_ylabel(f"{symbol}$_{i + 1}${unit_txt}")
        axes[3].set_ylabel(norm_label)
        axes[3].set_xlabel("time (s)")
        handles = [
            Line2D([], [], color=RUN_COLORS[k], linewidth=1.5, label=r.label)
            for k, r in enumerate(ctx.runs)
        ]
        if target is not None:
            handles.append(Line2D([], [], color="0.3", linestyle="--", label=target_label))
        handles += arrival_lines(ctx, axes) + fault_spans(ctx, axes)
        fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 3))
    fig.suptitle(f"{ctx.title}: {name}")
    return fig


def _attitude_error_deg(run: ReportRun) -> Floats:
    sc = run.scenario
    return arrival_time(
        run.run.t,
        run.run.sigma_bn,
        run.run.omega_b,
        sc.desired_mrp,
        sc.arrival.attitude_tol_deg,
        sc.arrival.rate_tol_rad_s,
    )[2]


def fig_history_mrp(ctx: FigureContext) -> Figure:
    return _history(
        ctx,
        "MRPs",
        r"$\sigma$",
        "-",
        lambda r: r.run.sigma_bn,
        "attitude error\nto goal (deg)",
        norm=_attitude_error_deg,
        target=lambda r: r.run.sigma_t,
        target_label="target sigma_t (dashed)",
    )


def fig_history_rate(ctx: FigureContext) -> Figure:
    return _history(
        ctx,
        "angular velocity",
        r"$\omega$",
        "rad/s",
        lambda r: r.run.omega_b,
        r"$|\omega|$ (rad/s)",
        bounds=lambda r: (None, r.scenario.actuators.max_rate_rad_s),
    )


def fig_history_torque(ctx: FigureContext) -> Figure:
    return _history(
        ctx,
        "control torque",
        r"$u$",
        "N m",
        lambda r: r.run.torque_b,
        r"$|u|$ (N m)",
        bounds=lambda r: (r.scenario.actuators.max_torque_nm, None),
    )
