"""MRP-space figures (in: the figure context; out: a 3D ``Figure``): the keep-out
regions and keep-in boundaries inside the unit ball, and the body and target MRP
trajectories among them."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import LightSource
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

from attitude_core.models.mrp import to_principal

from ..geometry import break_jumps
from .context import FigureContext
from .style import GOAL, START, pair_label

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["fig_keepout_mrp", "fig_trajectory_mrp"]


def _mrp_axes(fig: Figure, ctx: FigureContext) -> tuple[Any, list[Artist]]:
    """3D axes (mplot3d has no type information: Any) with the regions; legend handles."""
    ax: Any = fig.add_subplot(projection="3d", computed_zorder=False)
    handles: list[Artist] = []
    light = LightSource(azdeg=315, altdeg=35)
    for p, surf in ctx.surfaces():
        color = ctx.pair_color[p]
        handles.append(
            Patch(
                facecolor=color,
                alpha=0.6,
                label=pair_label(p, ctx.n_instruments)
                + (" at t = 0" if p.moving else "")
                + ("" if surf is not None else " (outside the unit ball)"),
            )
        )
        if surf is None:
            continue
        ax.add_collection3d(
            Poly3DCollection(
                surf, facecolors=color, alpha=0.33, linewidths=0.0, shade=True, lightsource=light
            )
        )
    for cone, surf in ctx.keep_in_surfaces():
        color = ctx.keep_in_color[cone]
        handles.append(
            Patch(
                facecolor=color,
                alpha=0.3,
                edgecolor=color,
                linestyle="--",
                label=f"{cone.key} boundary (keep-in)"
                + ("" if surf is not None else " (outside the unit ball)"),
            )
        )
        if surf is None:
            continue
        ax.add_collection3d(  # fainter than the keep-out regions: it wraps round them
            Poly3DCollection(
                surf,
                facecolors=color,
                alpha=0.12,
                linewidths=0.0,
                shade=True,
                lightsource=light,
                gid=f"{cone.key}/surface",
            )
        )
    u = np.linspace(0.0, 2.0 * np.pi, 37)
    w = np.linspace(0.0, np.pi, 19)
    ax.plot_wireframe(
        np.outer(np.cos(u), np.sin(w)),
        np.outer(np.sin(u), np.sin(w)),
        np.outer(np.ones_like(u), np.cos(w)),
        color="0.55",
        linewidth=0.35,
        alpha=0.45,
        rstride=2,
        cstride=2,
    )
    handles.append(Line2D([], [], color="0.55", linewidth=0.8, label="unit sphere |sigma| = 1"))
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-1.08, 1.08)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(r"$\sigma_1$")
    ax.set_ylabel(r"$\sigma_2$")
    ax.zaxis.set_rotate_label(False)
    ax.set_zlabel(r"$\sigma_3$", rotation=0)
    ticks = np.linspace(-1.0, 1.0, 5)
    ax.set_xticks(ticks)
    ax.set_yticks(ticks)
    ax.set_zticks(ticks)
    ax.view_init(elev=ctx.view[0], azim=ctx.view[1])
    return ax, handles


def fig_keepout_mrp(ctx: FigureContext) -> Figure:
    fig = plt.figure(figsize=(8.0, 8.2))
    ax, handles = _mrp_axes(fig, ctx)
    ax.set_title(f"{ctx.title}: keep-out regions in MRP space")
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=2,
        title="keep-out region: object"
        + (" / instrument" if ctx.n_instruments > 1 else f" ({ctx.pairs[0].instrument})"),
    )
    return fig


def fig_trajectory_mrp(ctx: FigureContext) -> Figure:
    fig = plt.figure(figsize=(8.0, 8.6))
    ax, handles = _mrp_axes(fig, ctx)
    traj: list[Artist] = []
    for k, run in enumerate(ctx.runs):
        color = ctx.run_color(k, "black")
        sc = run.scenario
        tag = f"{run.label}: " if ctx.compare else ""
        body = break_jumps(run.run.sigma_bn)
        target = break_jumps(run.run.sigma_t)
        ax.plot(*body.T, color=color, linewidth=2.4, zorder=10)
        ax.plot(
            *target.T,
            color=color,
            linestyle=(0, (4, 3)),
            linewidth=1.3,
            gapcolor="white",
            zorder=11,
        )
        s0 = to_principal(sc.initial_mrp)
        sd = to_principal(sc.desired_mrp)
        ax.plot(*[[x] for x in s0], markeredgecolor=color, zorder=12, **START)
        ax.plot(*[[x] for x in sd], markerfacecolor=color, zorder=12, **GOAL)
        traj += [
            Line2D([], [], color=color, linewidth=2.2, label=f"{tag}body sigma_BN"),
            Line2D(
                [],
                [],
                color=color,
                linewidth=1.3,
                linestyle="--",
                gapcolor="white",
                label=f"{tag}target sigma_t",
            ),
        ]
    traj += [
        Line2D([], [], color="black", label="start", **START),
        Line2D([], [], color="black", markerfacecolor="black", label="goal", **GOAL),
    ]
    ax.set_title(f"{ctx.title}: MRP trajectory")
    fig.legend(handles=traj + handles, loc="outside lower center", ncol=2)
    return fig
