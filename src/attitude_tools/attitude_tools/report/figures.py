"""The report's PNG figures (matplotlib, Agg backend), for one run or two overlaid.

The paper's simulation section shows the keep-out cones in the inertial frame and as
regions in MRP space (its Fig. "Keep-Out Constraints"), the MRP trajectory among the
regions and the boresight trajectory on the right ascension / declination plane
("Trajectory" figures), and the time histories of the MRPs, the angular velocity and
the torque ("Time History of the States"). ``FIGURES`` lists them, plus the margin of
every constraint against time.

Keep-in cones (a body axis that must stay within an angle of an inertial direction)
appear wherever keep-out cones do, drawn dashed in green and labelled ``keep_in/<name>``
(the summary's constraint label): the allowed cone on the sky, the axis' inertial track
in its own panel of the boresight figure, the boundary in MRP space and its margin
against time. Their artists carry ``gid`` ``keep_in/<name>/<part>`` (``cone``,
``axis``, ``surface``, ``margin``), so a test can find them.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.colors import LightSource
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

from attitude_core.gnc.mrp import Vec3, principal_angle, relative, to_principal
from attitude_core.record.metrics import arrival_time

from .data import ReportRun
from .geometry import (
    KeepIn,
    Pair,
    best_view,
    boresight_inertial,
    break_jumps,
    break_wraps,
    keep_in_margin_on_sky,
    keep_ins_of,
    mrp_surface,
    pair_margin_on_sky,
    pairs_of,
    ra_dec_deg,
    sky_grid,
    small_circle,
)
from .sky import constraint_margins_deg, draw_moving_pairs, instrument_title, pair_margins_deg

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.typing import RcKeyType

__all__ = ["FIGURES", "ESTIMATION_FIGURES", "figures_for", "render_figures"]

_Floats = npt.NDArray[np.float64]

# file name -> (title, what it shows); the order of the report.
FIGURES = {
    "keepout_inertial.png": (
        "Keep-out cones in the inertial frame",
        "Each cone (the instrument's half-angle about the bright object) drawn as a true "
        "small circle on the sky, right ascension / declination (paper: Keep-Out "
        "Constraints, inertial space); each keep-in cone (the largest angle allowed about "
        "its direction) dashed in green.",
    ),
    "keepout_mrp.png": (
        "Keep-out regions in MRP space",
        "Zero level set of the margin of each instrument/object pair inside the unit ball "
        "|sigma| <= 1 (marching cubes, clipped at the unit sphere, drawn as a wireframe) "
        "(paper: Keep-Out Constraints, MRP space); each keep-in cone's boundary (the zero "
        "level set of its margin) as a faint green surface, start and goal on its allowed "
        "side.",
    ),
    "trajectory_mrp.png": (
        "MRP trajectory among the keep-out regions",
        "Body sigma_BN (solid) and planner target sigma_t (dashed) in MRP space; start "
        "and goal marked (paper: MRP vector trajectory).",
    ),
    "trajectory_boresight.png": (
        "Boresight trajectory on the sky",
        "Each instrument's boresight C_BN^T s_i on the right ascension / declination "
        "plane among its keep-out cones, and each keep-in axis C_BN^T a_k with its allowed "
        "cone (dashed green); start and goal marked (paper: boresight vector trajectory).",
    ),
    "history_mrp.png": (
        "Time history of the MRPs",
        "Components of sigma_BN (solid) and of the target sigma_t (dashed); attitude "
        "error to the goal (paper: time history, MRPs).",
    ),
    "history_rate.png": (
        "Time history of the angular velocity",
        "Body rate omega_BN components and norm, rad/s (paper: time history, angular velocity).",
    ),
    "history_torque.png": (
        "Time history of the control torque",
        "Control torque components (body axes) and norm, N m (paper: time history, torque).",
    ),
    "margin.png": (
        "Constraint margins against time",
        "Angle between boresight and object minus the half-angle, for each "
        "instrument/object pair; for each keep-in cone (dashed, keep_in/<name>) the largest "
        "angle allowed minus the angle between its axis and its direction; negative is a "
        "violation.",
    ),
}

ESTIMATION_FIGURES = {
    "estimation.png": (
        "Estimate against truth",
        "Runs with sensors: the principal angle between the estimated attitude the loop was "
        "fed and the true body (deg) under the estimator's 3-sigma (3 sqrt(trace P_att), "
        "shaded), and the error of the bias-corrected rate estimate (rad/s); the knowledge "
        "3-sigma the guidance planned with dotted.",
    ),
}
"""Figures only for runs that were flown on an estimate (``RunResult.estimate``)."""


def figures_for(runs: Sequence[ReportRun]) -> dict[str, tuple[str, str]]:
    """The figures of a report on ``runs``: :data:`FIGURES`, and the estimation figure
    when a run was flown on an estimate."""
    if any(r.run.estimate is not None for r in runs):
        return {**FIGURES, **ESTIMATION_FIGURES}
    return dict(FIGURES)


RUN_COLORS = ("tab:blue", "tab:orange")
PAIR_COLORS = (  # no green: green is the keep-in cones'
    "tab:red",
    "tab:purple",
    "goldenrod",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "tab:cyan",
    "tab:gray",
)
KEEP_IN_COLORS = ("tab:green", "darkgreen", "yellowgreen", "mediumseagreen")
KEEP_IN_LINE: dict[str, Any] = dict(linestyle=(0, (5, 3)), linewidth=1.8)
COMPONENT_COLORS = ("tab:blue", "tab:orange", "tab:green")
STYLE: dict[RcKeyType, Any] = {
    "figure.dpi": 100,
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "axes.grid": True,
    "grid.alpha": 0.35,
    "figure.constrained_layout.use": True,
}
START: dict[str, Any] = dict(
    marker="o", markersize=8, markerfacecolor="white", markeredgewidth=1.8, linestyle="none"
)
GOAL: dict[str, Any] = dict(
    marker="D", markersize=7, markeredgecolor="black", markeredgewidth=1.0, linestyle="none"
)


def _keep_in_label(cone: KeepIn) -> str:
    axis = ", ".join(f"{x:.3g}" for x in cone.axis_body)
    return f"{cone.key}: axis [{axis}] within {cone.max_angle_deg:g} deg"


def _pair_label(pair: Pair, n_instruments: int) -> str:
    if pair.exclusion_deg is not None:  # a body with a radius: its exclusion from the limb
        angle = f"{pair.exclusion_deg:g} deg from the limb"
        if n_instruments == 1:
            return f"{pair.obj} ({angle})"
        return f"{pair.obj} / {pair.instrument} ({angle})"
    if n_instruments == 1:
        return f"{pair.obj} (half-angle {pair.half_angle_deg:g} deg)"
    return f"{pair.obj} / {pair.instrument} ({pair.half_angle_deg:g} deg)"


class _Context:
    """What every figure needs: the runs, their distinct cones, colours and names."""

    def __init__(self, runs: Sequence[ReportRun], mrp_grid: int) -> None:
        self.runs = runs
        self.pairs = pairs_of([r.scenario for r in runs])
        self.n_instruments = len({p.instrument_key for p in self.pairs})
        self.pair_color = {p: PAIR_COLORS[k % len(PAIR_COLORS)] for k, p in enumerate(self.pairs)}
        self.keep_ins = keep_ins_of([r.scenario for r in runs])
        self.keep_in_color = {
            c: KEEP_IN_COLORS[k % len(KEEP_IN_COLORS)] for k, c in enumerate(self.keep_ins)
        }
        self.mrp_grid = mrp_grid
        self._surfaces: list[tuple[Pair, _Floats | None]] | None = None
        self._keep_in_surfaces: list[tuple[KeepIn, _Floats | None]] | None = None
        pts = [to_principal(r.run.sigma_bn) for r in runs]
        pts += [
            to_principal(np.array([r.scenario.initial_mrp, r.scenario.desired_mrp])) for r in runs
        ]
        self.view = best_view(np.concatenate(pts))
        if len(runs) == 1:
            self.title = runs[0].label
        else:
            self.title = " vs ".join(r.label for r in runs)

    def run_color(self, k: int, default: str = "tab:blue") -> str:
        return RUN_COLORS[k] if len(self.runs) > 1 else default

    @property
    def compare(self) -> bool:
        return len(self.runs) > 1

    def surfaces(self) -> list[tuple[Pair, _Floats | None]]:
        if self._surfaces is None:
            self._surfaces = [(p, mrp_surface(p, self.mrp_grid)) for p in self.pairs]
        return self._surfaces

    def keep_in_surfaces(self) -> list[tuple[KeepIn, _Floats | None]]:
        if self._keep_in_surfaces is None:
            self._keep_in_surfaces = [(c, mrp_surface(c, self.mrp_grid)) for c in self.keep_ins]
        return self._keep_in_surfaces

    def instruments(self) -> list[tuple[str, Vec3, float | None]]:
        """Distinct instruments (name, boresight, half-angle or None), in order."""
        seen: list[tuple[str, Vec3, float | None]] = []
        for p in self.pairs:
            key = p.instrument_key
            if key not in seen:
                seen.append(key)
        return seen


# --- sky (right ascension / declination) ----------------------------------------------


def _sky_axes(ax: Axes) -> None:
    ax.set_xlim(0.0, 360.0)
    ax.set_ylim(-90.0, 90.0)
    ax.set_xticks(np.arange(0, 361, 60))
    ax.set_yticks(np.arange(-90, 91, 30))
    ax.set_aspect("equal")
    ax.set_xlabel("right ascension (deg)")
    ax.set_ylabel("declination (deg)")


_SKY: tuple[_Floats, _Floats, _Floats] | None = None


def _sky() -> tuple[_Floats, _Floats, _Floats]:
    global _SKY
    if _SKY is None:
        _SKY = sky_grid()
    return _SKY


def _draw_cones(
    ctx: _Context, ax: Axes, pairs: Iterable[Pair], boresight: bool = False
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
                facecolor=color, edgecolor=color, alpha=0.5, label=_pair_label(p, ctx.n_instruments)
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
        lambda p: _pair_label(p, ctx.n_instruments),
        _sky(),
        boresight=boresight,
    )


def _draw_keep_ins(ctx: _Context, ax: Axes, cones: Sequence[KeepIn]) -> list[Artist]:
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
        handles.append(Line2D([], [], color=color, label=_keep_in_label(cone), **KEEP_IN_LINE))
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


def fig_keepout_inertial(ctx: _Context) -> Figure:
    fig, ax = plt.subplots(figsize=(11.0, 4.9))
    handles = _draw_cones(ctx, ax, ctx.pairs)
    handles += _draw_keep_ins(ctx, ax, ctx.keep_ins)
    _sky_axes(ax)
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


def fig_trajectory_boresight(ctx: _Context) -> Figure:
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
        cone_handles = _draw_cones(ctx, ax, pairs, boresight=True)
        for k, run in enumerate(ctx.runs):
            sc = run.scenario
            match = [
                i
                for i, nm in enumerate(sc.instrument_names)
                if nm == name and np.allclose(sc.boresights_body[i], s_body)
            ]
            if not match:
                continue
            _sky_track(ax, run, s_body, ctx.run_color(k))
        _sky_axes(ax)
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


def _sky_track(
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


def _keep_in_axis_panel(ctx: _Context, ax: Axes, cone: KeepIn) -> None:
    """One keep-in cone on the sky: its allowed cone and each run's axis track."""
    handles = _draw_keep_ins(ctx, ax, [cone])
    for k, run in enumerate(ctx.runs):
        if _keep_in_index(run, cone) is None:
            continue
        _sky_track(ax, run, np.asarray(cone.axis_body), ctx.run_color(k), f"{cone.key}/axis")
    _sky_axes(ax)
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


# --- MRP space ----------------------------------------------------------------------


def _mrp_axes(fig: Figure, ctx: _Context) -> tuple[Any, list[Artist]]:
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
                label=_pair_label(p, ctx.n_instruments)
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


def fig_keepout_mrp(ctx: _Context) -> Figure:
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


def fig_trajectory_mrp(ctx: _Context) -> Figure:
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


# --- time histories -------------------------------------------------------------------


def _arrival_lines(ctx: _Context, axes: Iterable[Axes]) -> list[Artist]:
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
    ctx: _Context,
    name: str,
    symbol: str,
    unit: str,
    get: Callable[[ReportRun], _Floats],
    norm_label: str,
    norm: Callable[[ReportRun], _Floats] | None = None,
    target: Callable[[ReportRun], _Floats] | None = None,
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
        handles += _arrival_lines(ctx, (ax, axn))
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
        handles += _arrival_lines(ctx, axes)
        fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 3))
    fig.suptitle(f"{ctx.title}: {name}")
    return fig


def _attitude_error_deg(run: ReportRun) -> _Floats:
    sc = run.scenario
    return arrival_time(
        run.run.t,
        run.run.sigma_bn,
        run.run.omega_b,
        sc.desired_mrp,
        sc.arrival.attitude_tol_deg,
        sc.arrival.rate_tol_rad_s,
    )[2]


def fig_history_mrp(ctx: _Context) -> Figure:
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


def fig_history_rate(ctx: _Context) -> Figure:
    return _history(
        ctx,
        "angular velocity",
        r"$\omega$",
        "rad/s",
        lambda r: r.run.omega_b,
        r"$|\omega|$ (rad/s)",
        bounds=lambda r: (None, r.scenario.actuators.max_rate_rad_s),
    )


def fig_history_torque(ctx: _Context) -> Figure:
    return _history(
        ctx,
        "control torque",
        r"$u$",
        "N m",
        lambda r: r.run.torque_b,
        r"$|u|$ (N m)",
        bounds=lambda r: (r.scenario.actuators.max_torque_nm, None),
    )


# --- margin -------------------------------------------------------------------------


def _keep_in_index(run: ReportRun, cone: KeepIn) -> int | None:
    """Index of the run's keep-in cone equal to ``cone`` (None: the run has none)."""
    sc = run.scenario
    for k, name in enumerate(sc.keep_in_names):
        if (
            name == cone.name
            and np.allclose(sc.keep_in_axes_body[k], cone.axis_body)
            and np.allclose(sc.keep_in_directions_inertial[k], cone.direction_inertial)
            and abs(float(sc.keep_in_max_angles_deg[k]) - cone.max_angle_deg) < 1e-9
        ):
            return k
    return None


def _run_keep_in_margins(run: ReportRun, cone: KeepIn) -> _Floats | None:
    """Margin (deg) against time of the run's keep-in cone equal to ``cone``."""
    k = _keep_in_index(run, cone)
    if k is None:
        return None
    return constraint_margins_deg(run)[:, len(run.scenario.sky.pair_exclusion_deg) + k]


def _run_margins(run: ReportRun, constraint: Pair | KeepIn) -> _Floats | None:
    if isinstance(constraint, KeepIn):
        return _run_keep_in_margins(run, constraint)
    return pair_margins_deg(run, constraint)


def fig_margin(ctx: _Context) -> Figure:
    p: Pair | KeepIn | None  # a constraint, or None for the all-constraints panel
    constraints: list[Pair | KeepIn] = [*ctx.pairs, *ctx.keep_ins]
    if not ctx.compare:
        run = ctx.runs[0]
        fig, ax = plt.subplots(figsize=(9.0, 5.0))
        ax.axhspan(-180.0, 0.0, color="tab:red", alpha=0.07, linewidth=0)
        for p in ctx.pairs:  # the cones of this one run: each has its margins
            m = pair_margins_deg(run, p)
            assert m is not None
            ax.plot(
                run.run.t,
                m,
                color=ctx.pair_color[p],
                linewidth=1.6,
                label=p.key if not run.scenario.sky.static else f"{p.instrument} / {p.obj}",
                gid=f"{p.key}/margin",
            )
        for c in ctx.keep_ins:
            m = _run_keep_in_margins(run, c)
            assert m is not None
            ax.plot(
                run.run.t,
                m,
                color=ctx.keep_in_color[c],
                label=c.key,
                gid=f"{c.key}/margin",
                **KEEP_IN_LINE,
            )
        ax.axhline(0.0, color="black", linestyle="--", linewidth=1.0, label="zero margin")
        s = run.summary
        ax.plot(
            [s["t_min_margin_s"]],
            [s["min_margin_deg"]],
            marker="v",
            color="black",
            linestyle="none",
            markersize=7,
            label=f"minimum {s['min_margin_deg']:.2f} deg at {s['t_min_margin_s']:g} s",
        )
        _margin_limits(ax, [_run_margins(run, c) for c in constraints])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("keep-out margin (deg)" if not ctx.keep_ins else "margin (deg)")
        title = "instrument / object" + (", keep-in cone" if ctx.keep_ins else "")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title=title)
        ax.set_title(f"{ctx.title}: {'keep-out ' if not ctx.keep_ins else 'constraint '}margin")
        return fig
    # Comparison: the smallest margin over all constraints, then one panel per constraint.
    panels = [None, *constraints]
    n = len(panels)
    ncols = 2
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(6.0 * ncols, 3.3 * nrows + 0.8), squeeze=False, sharex=True
    )
    for ax, p in zip(axes.flat, panels, strict=False):
        series: list[_Floats] = []
        for k, run in enumerate(ctx.runs):
            if p is None:
                m = constraint_margins_deg(run).min(axis=-1)
                s = run.summary
                ax.plot(
                    [s["t_min_margin_s"]],
                    [s["min_margin_deg"]],
                    marker="v",
                    color=RUN_COLORS[k],
                    markeredgecolor="black",
                    linestyle="none",
                    markersize=7,
                    zorder=5,
                )
            else:
                m = _run_margins(run, p)
            if m is None:
                continue
            series.append(m)
            style = KEEP_IN_LINE if isinstance(p, KeepIn) else {"linewidth": 1.5}
            gid = f"{p.key}/margin" if p is not None else "all/margin"
            ax.plot(run.run.t, m, color=RUN_COLORS[k], gid=gid, **style)
        ax.axhspan(-180.0, 0.0, color="tab:red", alpha=0.07, linewidth=0)
        ax.axhline(0.0, color="black", linestyle="--", linewidth=1.0)
        _margin_limits(ax, series)
        if p is None:
            ax.set_title(f"all {'constraints' if ctx.keep_ins else 'pairs'}: smallest margin")
        elif isinstance(p, KeepIn):
            ax.set_title(f"{p.key} (keep-in)", color=ctx.keep_in_color[p])
        else:  # on a moving sky, the constraint's name
            moving = not all(r.scenario.sky.static for r in ctx.runs)
            ax.set_title(p.key if moving else f"{p.instrument} / {p.obj}", color=ctx.pair_color[p])
        ax.set_ylabel("margin (deg)")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    for col in range(ncols):  # the lowest visible panel of each column carries the time axis
        visible = [axes[r, col] for r in range(nrows) if r * ncols + col < n]
        visible[-1].xaxis.set_tick_params(labelbottom=True)
        visible[-1].set_xlabel("time (s)")
    handles = [
        Line2D([], [], color=RUN_COLORS[k], linewidth=1.5, label=r.label)
        for k, r in enumerate(ctx.runs)
    ]
    handles.append(Line2D([], [], color="black", linestyle="--", label="zero margin"))
    handles.append(
        Line2D(
            [],
            [],
            marker="v",
            color="0.5",
            markeredgecolor="black",
            linestyle="none",
            label="minimum (between steps too)",
        )
    )
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles))
    per = "instrument / object" + (" and keep-in cone" if ctx.keep_ins else "")
    fig.suptitle(f"{ctx.title}: {'keep-out ' if not ctx.keep_ins else ''}margin per {per}")
    return fig


def _margin_limits(ax: Axes, series: Iterable[_Floats | None]) -> None:
    values = np.concatenate([np.asarray(s) for s in series if s is not None])
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    pad = 0.06 * max(hi - min(lo, 0.0), 1.0)
    ax.set_ylim(min(lo, 0.0) - pad, hi + pad)


def fig_estimation(ctx: _Context) -> Figure:
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(9.0, 6.6), sharex=True)
    handles: list[Artist] = []
    for k, run in enumerate(ctx.runs):
        est = run.run.estimate
        if est is None:
            continue
        color = ctx.run_color(k)
        t = run.run.t
        err = np.degrees(principal_angle(relative(est.sigma_bn, run.run.sigma_bn)))
        ax.fill_between(t, 0.0, est.attitude_3sigma_deg, color=color, alpha=0.2, linewidth=0)
        ax.plot(t, err, color=color, linewidth=1.2, gid=f"{run.label}/attitude_error")
        knowledge = run.scenario.knowledge.attitude_3sigma_deg
        ax.axhline(knowledge, color=color, linestyle=":", linewidth=1.2)
        rate_err = np.linalg.norm(est.omega_b - run.run.omega_b, axis=1)
        axr.plot(t, rate_err, color=color, linewidth=1.0)
        axr.axhline(run.scenario.knowledge.rate_3sigma_rad_s, color=color, linestyle=":")
        suffix = f" {run.label}" if ctx.compare else ""
        handles += [
            Line2D([], [], color=color, linewidth=1.2, label=f"error{suffix}"),
            Patch(color=color, alpha=0.2, label=f"filter 3-sigma{suffix}"),
            Line2D([], [], color=color, linestyle=":", label=f"knowledge 3-sigma{suffix}"),
        ]
    ax.set_ylabel("attitude estimate\nerror (deg)")
    axr.set_ylabel("rate estimate\nerror (rad/s)")
    axr.set_xlabel("time (s)")
    handles += _arrival_lines(ctx, (ax, axr))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{ctx.title}: estimate against truth")
    return fig


_BUILDERS: dict[str, Callable[[_Context], Figure]] = {
    "keepout_inertial.png": fig_keepout_inertial,
    "keepout_mrp.png": fig_keepout_mrp,
    "trajectory_mrp.png": fig_trajectory_mrp,
    "trajectory_boresight.png": fig_trajectory_boresight,
    "history_mrp.png": fig_history_mrp,
    "history_rate.png": fig_history_rate,
    "history_torque.png": fig_history_torque,
    "margin.png": fig_margin,
    "estimation.png": fig_estimation,
}


def render_figures(
    runs: Sequence[ReportRun], out_dir: str, dpi: int = 120, mrp_grid: int = 48
) -> list[str]:
    """Write every figure of :func:`figures_for` the runs into ``out_dir``; their names."""
    ctx = _Context(runs, mrp_grid)
    written: list[str] = []
    with matplotlib.rc_context(STYLE):
        for name in figures_for(runs):
            fig = _BUILDERS[name](ctx)
            try:
                fig.savefig(
                    os.path.join(out_dir, name), dpi=dpi, bbox_inches="tight", pad_inches=0.12
                )
            finally:
                plt.close(fig)
            written.append(name)
    return written
