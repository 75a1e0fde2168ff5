"""The goals figure (in: the figure context; out: a ``Figure``): one row per goal of the
first run that has goals (a plan's targets, goals received on ``/planner/goal``): the
first instrument's boresight on the sky while the goal was in force, among its keep-out
cones, from where it was to the goal; and every constraint's margin over that window,
with the goal's arrival marked. A refused goal has a row saying why."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from attitude_core.record.goal_figures import final_goals, in_force_rows

from ..geometry import boresight_inertial, break_wraps, ra_dec_deg
from ..sky import constraint_margins_deg
from .context import FigureContext
from .sky_layers import draw_cones, sky_axes
from .style import GOAL, START

__all__ = ["fig_goals"]


def fig_goals(ctx: FigureContext) -> Figure:
    run = next(r for r in ctx.runs if r.run.goals)
    goals = final_goals(run.run)
    sc = run.scenario
    name, s_body, beta = ctx.instruments()[0]
    pairs = [p for p in ctx.pairs if p.instrument_key == (name, s_body, beta)]
    margins = constraint_margins_deg(run)
    t = run.run.t
    fig, axes = plt.subplots(
        len(goals), 2, figsize=(13.0, 3.6 * len(goals) + 0.6), squeeze=False,
        gridspec_kw={"width_ratios": [1.6, 1.0]},
    )  # fmt: skip
    for (sky, margin), goal in zip(axes, goals, strict=True):
        rows = in_force_rows(run.run, goal)
        title = f"{goal.name}: {goal.outcome.value}"
        if rows.stop <= rows.start:  # never in force (refused on receipt or at its turn)
            for ax in (sky, margin):
                ax.axis("off")
            sky.set_title(title)
            sky.text(0.0, 0.5, goal.reason or "never in force", wrap=True, fontsize=9)
            continue
        draw_cones(ctx, sky, pairs, boresight=True)
        track = boresight_inertial(run.run.sigma_bn[rows], s_body)
        sky.plot(*break_wraps(*ra_dec_deg(track)), color="black", linewidth=2.0, zorder=5)
        goal_dir = boresight_inertial(np.asarray(goal.sigma_goal)[None], s_body)[0]
        sky.plot(*ra_dec_deg(track[0]), markeredgecolor="black", zorder=6, **START)
        sky.plot(*ra_dec_deg(goal_dir), markerfacecolor="black", zorder=6, **GOAL)
        sky_axes(sky)
        sky.set_title(f"{title} ({name} boresight, {goal.rotation_deg:.1f} deg to go)")
        for c, label in enumerate(sc.constraint_names):
            margin.plot(t[rows], margins[rows, c], linewidth=1.3, label=label)
        margin.axhline(0.0, color="#9b1c1c", linewidth=1.0)
        if not math.isnan(goal.t_reach_s):
            margin.axvline(goal.t_reach_s, color="black", linestyle=":", label="arrival")
        low = float(np.min(margins[rows]))
        margin.set_title(f"margins while in force (smallest {low:.2f} deg at the samples)")
        margin.set_xlabel("time (s)")
        margin.set_ylabel("margin (deg)")
        margin.legend(fontsize=7, loc="upper right")
    return fig
