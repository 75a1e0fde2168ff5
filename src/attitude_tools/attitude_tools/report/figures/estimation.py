"""The estimation figure (in: the figure context; out: a ``Figure``): for runs flown
on an estimate, the attitude and rate estimate errors against truth under the
filter's and the planned knowledge's 3-sigma."""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from attitude_core.models.mrp import principal_angle, relative

from .context import FigureContext
from .histories import arrival_lines

if TYPE_CHECKING:
    from matplotlib.artist import Artist

__all__ = ["fig_estimation"]


def fig_estimation(ctx: FigureContext) -> Figure:
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
    handles += arrival_lines(ctx, (ax, axr))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{ctx.title}: estimate against truth")
    return fig
