"""Sky-map figures on the right ascension / declination plane (in: the figure context;
out: a ``Figure``): the keep-out and keep-in cones in the inertial frame, and each
instrument's boresight (and each keep-in axis) trajectory among them."""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..geometry import KeepIn
from ..sky import instrument_title
from .context import FigureContext
from .margin_series import keep_in_index
from .sky_layers import draw_cones, draw_keep_ins, sky_axes, sky_track
from .style import GOAL, START

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["fig_keepout_inertial", "fig_trajectory_boresight"]


def fig_keepout_inertial(ctx: FigureContext) -> Figure:
    fig, ax = plt.subplots(figsize=(11.0, 4.9))
    handles = draw_cones(ctx, ax, ctx.pairs)
    handles += draw_keep_ins(ctx, ax, ctx.keep_ins)
    sky_axes(ax)
    kinds = "keep-out and keep-in cones" if ctx.keep_ins else "keep-out cones"
    moving = " (moving objects: tracks, cones at start, closest approach, end)"
    ax.set_title(
        f"{ctx.title}: {kinds} in the inertial frame"
        + (moving if any(p.moving for p in ctx.pairs) else "")
    )
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        title="keep-out cone: object"
        + (" / instrument" if ctx.n_instruments > 1 else f"\n({ctx.pairs[0].instrument})"),
    )
    return fig


def fig_trajectory_boresight(ctx: FigureContext) -> Figure:
    instruments = ctx.instruments()
    n = len(instruments) + len(ctx.keep_ins)
    fig, axes = plt.subplots(n, 1, figsize=(11.0, 4.5 * n + 0.7), squeeze=False)
    run_handles: list[Artist] = []
    for k, run in enumerate(ctx.runs):
        color = ctx.run_color(k)
        label = run.label if ctx.compare else "boresight" + (" / axis" if ctx.keep_ins else "")
        run_handles.append(Line2D([], [], color=color, linewidth=2.0, label=label))
    run_handles += [
        Line2D([], [], color="black", label="start", **START),
        Line2D([], [], color="black", markerfacecolor="black", label="goal", **GOAL),
    ]
    for ax, cone in zip(axes[len(instruments) :, 0], ctx.keep_ins, strict=True):
        _keep_in_axis_panel(ctx, ax, cone)
    for ax, (name, s_body, beta) in zip(axes[: len(instruments), 0], instruments, strict=True):
        pairs = [p for p in ctx.pairs if p.instrument_key == (name, s_body, beta)]
        cone_handles = draw_cones(ctx, ax, pairs, boresight=True)
        for k, run in enumerate(ctx.runs):
            sc = run.scenario
            match = [
                i
                for i, nm in enumerate(sc.instrument_names)
                if nm == name and np.allclose(sc.boresights_body[i], s_body)
            ]
            if not match:
                continue
            sky_track(ax, run, s_body, ctx.run_color(k))
        sky_axes(ax)
        ax.set_title(instrument_title(name, s_body, beta, pairs))
        ax.legend(
            handles=cone_handles,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            title="keep-out cone",
            fontsize=8,
            title_fontsize=9,
        )
    fig.suptitle(f"{ctx.title}: boresight trajectory on the sky")
    fig.legend(handles=run_handles, loc="outside lower center", ncol=len(run_handles))
    return fig


def _keep_in_axis_panel(ctx: FigureContext, ax: Axes, cone: KeepIn) -> None:
    """One keep-in cone on the sky: its allowed cone and each run's axis track."""
    handles = draw_keep_ins(ctx, ax, [cone])
    for k, run in enumerate(ctx.runs):
        if keep_in_index(run, cone) is None:
            continue
        sky_track(ax, run, np.asarray(cone.axis_body), ctx.run_color(k), f"{cone.key}/axis")
    sky_axes(ax)
    ax.set_title(
        f"{cone.key}: axis [{', '.join(f'{x:.3g}' for x in cone.axis_body)}] (body), "
        f"within {cone.max_angle_deg:g} deg of its direction"
    )
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        title="keep-in cone (inside allowed)",
        fontsize=8,
        title_fontsize=9,
    )
