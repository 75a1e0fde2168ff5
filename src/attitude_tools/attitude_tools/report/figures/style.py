"""Shared look of the figures: colours, line and marker styles, rc settings, and the
legend labels of keep-out pairs and keep-in cones (in: a ``Pair`` / ``KeepIn``, out:
its label)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..geometry import KeepIn, Pair

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

__all__ = [
    "RUN_COLORS",
    "PAIR_COLORS",
    "KEEP_IN_COLORS",
    "KEEP_IN_LINE",
    "COMPONENT_COLORS",
    "WHEEL_COLORS",
    "STYLE",
    "START",
    "GOAL",
    "keep_in_label",
    "pair_label",
]

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
WHEEL_COLORS = (  # not the components' blue, orange, green (the momentum in the same
    # figure, the compared runs' arrival lines), nor red (safe mode)
    "tab:purple",
    "tab:brown",
    "tab:cyan",
    "tab:pink",
    "tab:olive",
    "goldenrod",
    "tab:gray",
    "darkslateblue",
)
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


def keep_in_label(cone: KeepIn) -> str:
    axis = ", ".join(f"{x:.3g}" for x in cone.axis_body)
    return f"{cone.key}: axis [{axis}] within {cone.max_angle_deg:g} deg"


def pair_label(pair: Pair, n_instruments: int) -> str:
    if pair.exclusion_deg is not None:  # a body with a radius: its exclusion from the limb
        angle = f"{pair.exclusion_deg:g} deg from the limb"
        if n_instruments == 1:
            return f"{pair.obj} ({angle})"
        return f"{pair.obj} / {pair.instrument} ({angle})"
    if n_instruments == 1:
        return f"{pair.obj} (half-angle {pair.half_angle_deg:g} deg)"
    return f"{pair.obj} / {pair.instrument} ({pair.half_angle_deg:g} deg)"
