"""Build and write the figures (in: the runs, an output directory, dpi and MRP grid
size; out: the PNG files of :func:`~.catalog.figures_for` the runs, and their names)."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

import matplotlib
import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from ..data import ReportRun
from .catalog import figures_for
from .context import FigureContext
from .estimation import fig_estimation
from .goals import fig_goals
from .histories import fig_history_mrp, fig_history_rate, fig_history_torque
from .margin import fig_margin
from .mrp_space import fig_keepout_mrp, fig_trajectory_mrp
from .sky_maps import fig_keepout_inertial, fig_trajectory_boresight
from .style import STYLE
from .wheels import fig_wheels

__all__ = ["render_figures"]

_BUILDERS: dict[str, Callable[[FigureContext], Figure]] = {
    "keepout_inertial.png": fig_keepout_inertial,
    "keepout_mrp.png": fig_keepout_mrp,
    "trajectory_mrp.png": fig_trajectory_mrp,
    "trajectory_boresight.png": fig_trajectory_boresight,
    "history_mrp.png": fig_history_mrp,
    "history_rate.png": fig_history_rate,
    "history_torque.png": fig_history_torque,
    "margin.png": fig_margin,
    "estimation.png": fig_estimation,
    "wheels.png": fig_wheels,
    "goals.png": fig_goals,
}


def render_figures(
    runs: Sequence[ReportRun], out_dir: str, dpi: int = 120, mrp_grid: int = 48
) -> list[str]:
    """Write every figure of :func:`figures_for` the runs into ``out_dir``; their names."""
    ctx = FigureContext(runs, mrp_grid)
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
