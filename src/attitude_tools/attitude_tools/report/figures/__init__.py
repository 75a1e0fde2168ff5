"""The report's PNG figures (matplotlib, Agg backend), for one run or two overlaid.

In: the :class:`~attitude_tools.report.data.ReportRun` s of a report. Out: PNG files
(:func:`render_figures`) named and captioned by :data:`FIGURES` /
:func:`figures_for`. One module per job: ``catalog`` (the figure list and captions),
``style`` (colours, line styles, labels), ``context`` (what every figure shares),
``sky_layers`` and ``sky_maps`` (right ascension / declination plots),
``mrp_space`` (3D MRP-space plots), ``histories`` (MRP, rate and torque against
time), ``margin_series`` and ``margin`` (constraint margins against time),
``estimation`` (estimate against truth), ``wheels`` (wheel speeds and torques against
their limits, the system momentum) and ``render`` (builds and writes them).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # before any submodule imports pyplot

from .catalog import ESTIMATION_FIGURES, FIGURES, WHEEL_ARRAY_FIGURES, figures_for
from .context import FigureContext
from .estimation import fig_estimation
from .render import render_figures
from .wheels import fig_wheels

__all__ = [
    "FIGURES",
    "ESTIMATION_FIGURES",
    "WHEEL_ARRAY_FIGURES",
    "FigureContext",
    "figures_for",
    "render_figures",
    "fig_estimation",
    "fig_wheels",
]
