"""Layers drawn on a right ascension / declination axes (in: the figure context and an
``Axes``; out: the artists drawn, and legend handles): the sky frame, keep-out cones
with their objects, keep-in cones, and a body vector's inertial track."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..data import ReportRun
from ..geometry import (
    KeepIn,
    Pair,
    boresight_inertial,
    break_wraps,
    keep_in_margin_on_sky,
    pair_margin_on_sky,
    ra_dec_deg,
    sky_grid,
    small_circle,
)
from ..sky import draw_moving_pairs
from .context import FigureContext, Floats
from .style import GOAL, KEEP_IN_LINE, START, keep_in_label, pair_label

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["sky_axes", "draw_cones", "draw_keep_ins", "sky_track"]


def sky_axes(ax: Axes) -> None:
    ax.set_xlim(0.0, 360.0)
    ax.set_ylim(-90.0, 90.0)
    ax.set_xticks(np.arange(0, 361, 60))
    ax.set_yticks(np.arange(-90, 91, 30))
    ax.set_aspect("equal")
    ax.set_xlabel("right ascension (deg)")
    ax.set_ylabel("declination (deg)")


_SKY: tuple[Floats, Floats, Floats] | None = None


def _sky() -> tuple[Floats, Floats, Floats]:
    global _SKY
    if _SKY is None:
        _SKY = sky_grid()
    return _SKY


def draw_cones(
    ctx: FigureContext, ax: Axes, pairs: Iterable[Pair], boresight: bool = False
) -> list[Artist]:
    """Filled cones with true-circle outlines and the objects; legend handles. Moving
    objects' cones: ``sky.draw_moving_pairs`` (with ``boresight``, the boresight at each
    closest approach too)."""
    ra, dec, v = _sky()
    handles: list[Artist] = []
    objects: dict[tuple[float, float, float], str] = {}
    fixed = [p for p in pairs if not p.moving]
    moving = [p for p in pairs if p.moving]
    for p in fixed:
        color = ctx.pair_color[p]
        margin = pair_margin_on_sky(p, v)
        ax.contourf(ra, dec, margin, levels=[margin.min() - 1.0, 0.0], colors=[color], alpha=0.22)
        cra, cdec = break_wraps(*ra_dec_deg(small_circle(p.direction_inertial, p.half_angle_deg)))
        ax.plot(
            cra, cdec, color=color, linewidth=1.6, solid_capstyle="round", solid_joinstyle="round"
        )
        handles.append(
            Patch(
                facecolor=color, edgecolor=color, alpha=0.5, label=pair_label(p, ctx.n_instruments)
            )
        )
        objects.setdefault(p.direction_inertial, p.obj)
    for direction, name in objects.items():
        ora, odec = ra_dec_deg(np.array(direction))
        ax.plot(
            ora,
            odec,
            marker="*",
            color="black",
            markersize=9,
            linestyle="none",
            clip_on=False,
            zorder=7,
        )
        ax.annotate(
            name,
            (ora, odec),
            xytext=(5, 4),
            textcoords="offset points",
            fontsize=8,
            annotation_clip=False,
        )
    if fixed or not moving:
        handles.append(
            Line2D(
                [],
                [],
                marker="*",
                color="black",
                linestyle="none",
                markersize=9,
                label="bright object direction",
            )
        )
    return handles + draw_moving_pairs(
        ax,
        ctx.runs,
        moving,
        ctx.pair_color,
        lambda p: pair_label(p, ctx.n_instruments),
        _sky(),
        boresight=boresight,
    )


def draw_keep_ins(ctx: FigureContext, ax: Axes, cones: Sequence[KeepIn]) -> list[Artist]:
    """Keep-in cones: the allowed region lightly filled, its boundary dashed, the
    direction marked; legend handles."""
    ra, dec, v = _sky()
    handles: list[Artist] = []
    for cone in cones:
        color = ctx.keep_in_color[cone]
        margin = keep_in_margin_on_sky(cone, v)
        if margin.max() > 0.0:
            top = margin.max() + 1.0
            ax.contourf(ra, dec, margin, levels=[0.0, top], colors=[color], alpha=0.08)
        cra, cdec = break_wraps(
            *ra_dec_deg(small_circle(cone.direction_inertial, cone.max_angle_deg))
        )
        ax.plot(cra, cdec, color=color, gid=f"{cone.key}/cone", zorder=4, **KEEP_IN_LINE)
        dra, ddec = ra_dec_deg(np.array(cone.direction_inertial))
        ax.plot(
            dra,
            ddec,
            marker="P",
            color=color,
            markeredgecolor="black",
            markersize=9,
            linestyle="none",
            clip_on=False,
            zorder=7,
        )
        ax.annotate(
            cone.key,
            (dra, ddec),
            xytext=(5, -10),
            textcoords="offset points",
            fontsize=8,
            color=color,
            annotation_clip=False,
        )
        handles.append(Line2D([], [], color=color, label=keep_in_label(cone), **KEEP_IN_LINE))
    if cones:
        handles.append(
            Line2D(
                [],
                [],
                marker="P",
                color="tab:green",
                markeredgecolor="black",
                linestyle="none",
                markersize=9,
                label="keep-in direction",
            )
        )
    return handles


def sky_track(
    ax: Axes, run: ReportRun, vector_body: npt.ArrayLike, color: str, gid: str | None = None
) -> None:
    """A body vector's inertial track over a run on the sky, with its start and goal."""
    sc = run.scenario
    track = boresight_inertial(run.run.sigma_bn, vector_body)
    ax.plot(*break_wraps(*ra_dec_deg(track)), color=color, linewidth=2.0, zorder=5, gid=gid)
    start = ra_dec_deg(boresight_inertial(sc.initial_mrp[None], vector_body)[0])
    goal = ra_dec_deg(boresight_inertial(sc.desired_mrp[None], vector_body)[0])
    ax.plot(*start, markeredgecolor=color, zorder=6, **START)
    ax.plot(*goal, markerfacecolor=color, zorder=6, **GOAL)
