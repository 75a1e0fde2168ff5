"""The constraint-margin figure (in: the figure context; out: a ``Figure``): every
keep-out pair's and keep-in cone's margin against time, one panel per constraint
(after the smallest of all) when comparing runs."""

from __future__ import annotations

from collections.abc import Iterable

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..geometry import KeepIn, Pair
from ..sky import constraint_margins_deg, pair_margins_deg
from .context import FigureContext, Floats
from .histories import fault_spans
from .margin_series import run_keep_in_margins, run_margins
from .style import KEEP_IN_LINE, RUN_COLORS

__all__ = ["fig_margin"]


def fig_margin(ctx: FigureContext) -> Figure:
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
            m = run_keep_in_margins(run, c)
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
        _margin_limits(ax, [run_margins(run, c) for c in constraints])
        ax.set_xlabel("time (s)")
        ax.set_ylabel("keep-out margin (deg)" if not ctx.keep_ins else "margin (deg)")
        title = "instrument / object" + (", keep-in cone" if ctx.keep_ins else "")
        faults = fault_spans(ctx, [ax])  # the run's faults on its timeline
        handles = ax.get_legend_handles_labels()[0] + faults
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), title=title)
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
        series: list[Floats] = []
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
                m = run_margins(run, p)
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


def _margin_limits(ax: Axes, series: Iterable[Floats | None]) -> None:
    values = np.concatenate([np.asarray(s) for s in series if s is not None])
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    pad = 0.06 * max(hi - min(lo, 0.0), 1.0)
    ax.set_ylim(min(lo, 0.0) - pad, hi + pad)
