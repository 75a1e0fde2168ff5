"""The report on a moving sky: the margins it plots and the moving objects on the sky plots.

Margins (:func:`constraint_margins_deg`) are those of ``attitude_core.record.summary``:
one column per ``Scenario.constraint_names``, each attitude against the sky of its own
instant (on a static sky the sky's fixed geometry, the paper's eq. 5: the same numbers as
the per-pair margins at the instrument's half-angle). Every plotted margin is one column.

A moving object (an ephemeris body, or a direction turning at a constant rate) has no
fixed keep-out cone: :func:`draw_moving_pairs` draws its track over the run
(:func:`object_track`, its direction every :data:`TRACK_STEP_S`), and for each
instrument that avoids it the cone's outline (the exclusion from the limb plus the
object's angular radius at that time) at the start of the run (dotted), at its end
(dashed) and at the closest approach (solid and filled: the time of the pair's smallest
margin at the samples). Artists carry ``gid`` ``<object>/track``,
``<instrument>/<object>/cone_start``, ``.../cone_end``, ``.../cone_closest`` and (on the
boresight figure) ``.../closest_boresight``, so a test can find them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from attitude_core.record.summary import constraint_margins_deg as _scenario_margins_deg

from .data import ReportRun
from .geometry import (
    Pair,
    boresight_inertial,
    break_wraps,
    pair_index,
    pair_margin_on_sky,
    ra_dec_deg,
    small_circle,
)

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

__all__ = [
    "TRACK_STEP_S",
    "constraint_margins_deg",
    "pair_margins_deg",
    "track_times",
    "object_track",
    "closest_approach",
    "pair_cone_at",
    "draw_moving_pairs",
    "instrument_title",
]

_Floats = npt.NDArray[np.float64]

TRACK_STEP_S = 1.0
"""Spacing of the drawn object tracks, s (the run's start and end always included)."""

CONE_TIMES: dict[str, dict[str, Any]] = {  # cone outline drawn at: line style
    "start": dict(linestyle=(0, (1.0, 1.6)), linewidth=1.5),
    "end": dict(linestyle=(0, (5.0, 2.5)), linewidth=1.4),
    "closest": dict(linestyle="-", linewidth=1.7),
}
TRACK: dict[str, Any] = dict(color="0.25", linewidth=1.1, zorder=3)


def constraint_margins_deg(run: ReportRun) -> _Floats:
    """Margins ``(N, n_c)``, deg, of the run's attitudes at its samples: one column per
    ``Scenario.constraint_names``, each against the sky of its instant."""
    return _scenario_margins_deg(run.scenario, run.run.t, run.run.sigma_bn)


def pair_margins_deg(run: ReportRun, pair: Pair) -> _Floats | None:
    """The margin series of the run's constraint equal to ``pair`` (None: it has none)."""
    c = pair_index(run.scenario, pair)
    return None if c is None else constraint_margins_deg(run)[:, c]


def track_times(run: ReportRun, step_s: float = TRACK_STEP_S) -> _Floats:
    """Times of a drawn track: the run's first to last sample, every ``step_s``."""
    t0, t1 = float(run.run.t[0]), float(run.run.t[-1])
    n = max(math.ceil((t1 - t0) / step_s - 1e-9), 1)
    times: _Floats = np.linspace(t0, t1, n + 1)
    return times


def object_track(run: ReportRun, obj: str) -> tuple[_Floats, _Floats, _Floats]:
    """Object ``obj``'s track over the run: times (:func:`track_times`), unit directions
    ``(n, 3)`` (inertial axes) and angular radii ``(n,)``, deg."""
    t = track_times(run)
    j = run.scenario.bright_object_names.index(obj)
    directions, radii = run.scenario.sky.object_directions(t)
    return t, directions[:, j], radii[:, j]


def closest_approach(run: ReportRun, pair: Pair) -> tuple[int, float] | None:
    """(sample, time) of the pair's smallest margin in the run (None: not its pair)."""
    m = pair_margins_deg(run, pair)
    if m is None:
        return None
    k = int(np.argmin(m))
    return k, float(run.run.t[k])


def pair_cone_at(run: ReportRun, pair: Pair, t_s: float) -> tuple[_Floats, float]:
    """The pair's keep-out cone at ``t_s``: its object's direction and the cone's angle
    (the exclusion from the limb plus the object's angular radius), deg."""
    sky = run.scenario.sky
    c = pair_index(run.scenario, pair)
    assert c is not None, pair
    j = int(sky.pair_object[c])
    directions, radii = sky.object_directions(t_s)
    return directions[j], float(sky.pair_exclusion_deg[c] + radii[j])


def instrument_title(
    name: str, s_body: tuple[float, float, float], beta: float | None, pairs: Sequence[Pair]
) -> str:
    """A boresight panel's title: the instrument's half-angle (the paper's sky), else its
    keep-out angle of each object it avoids."""
    head = f"{name}: boresight [{', '.join(f'{x:g}' for x in s_body)}] (body), "
    if beta is not None and all(
        p.exclusion_deg is None and p.half_angle_deg == beta for p in pairs
    ):
        return head + f"half-angle {beta:g} deg"
    limb = " from the limb" if any(p.exclusion_deg is not None for p in pairs) else ""
    angles = ", ".join(f"{p.obj} {p.exclusion:g}" for p in pairs)
    return f"{head}keep-out {angles} deg{limb}"


def _circle(ax: Axes, centre: _Floats, angle_deg: float, color: str, tag: str, gid: str) -> None:
    cra, cdec = break_wraps(*ra_dec_deg(small_circle(centre, angle_deg)))
    ax.plot(cra, cdec, color=color, gid=gid, zorder=4, **CONE_TIMES[tag])


def _draw_track(ax: Axes, run: ReportRun, obj: str, drawn: list[tuple[str, _Floats]]) -> None:
    """The object's track, its place at the start (hollow star) and at the end (star),
    once per distinct track."""
    _, track, _ = object_track(run, obj)
    if any(name == obj and np.allclose(track, other) for name, other in drawn):
        return
    drawn.append((obj, track))
    ax.plot(*break_wraps(*ra_dec_deg(track)), gid=f"{obj}/track", **TRACK)
    star: dict[str, Any] = dict(
        marker="*", markersize=10, linestyle="none", clip_on=False, zorder=7, color="black"
    )
    ax.plot(*ra_dec_deg(track[0]), markerfacecolor="white", **star)
    end_ra, end_dec = ra_dec_deg(track[-1])
    ax.plot(end_ra, end_dec, **star)
    ax.annotate(
        obj,
        (end_ra, end_dec),
        xytext=(5, 4),
        textcoords="offset points",
        fontsize=8,
        annotation_clip=False,
    )


def draw_moving_pairs(
    ax: Axes,
    runs: Sequence[ReportRun],
    pairs: Sequence[Pair],
    colors: Mapping[Pair, str],
    label: Callable[[Pair], str],
    grid: tuple[_Floats, _Floats, _Floats],
    boresight: bool = False,
) -> list[Artist]:
    """The moving pairs on the sky axes ``ax`` (module docstring) for each run that has
    them; with ``boresight``, the boresight at each closest approach too. ``grid`` is
    ``geometry.sky_grid()``. Returns the legend handles."""
    ra, dec, v = grid
    handles: list[Artist] = []
    tracks: list[tuple[str, _Floats]] = []
    for p in pairs:
        color = colors[p]
        drawn: set[tuple[str, float]] = set()
        closest: list[str] = []
        for run in runs:
            found = closest_approach(run, p)
            if found is None:
                continue
            k, t_closest = found
            _draw_track(ax, run, p.obj, tracks)
            t = track_times(run)
            for tag, when in (("start", t[0]), ("end", t[-1]), ("closest", t_closest)):
                if (tag, round(when, 6)) in drawn:
                    continue
                drawn.add((tag, round(when, 6)))
                centre, angle = pair_cone_at(run, p, when)
                _circle(ax, centre, angle, color, tag, f"{p.key}/cone_{tag}")
                if tag == "closest":
                    cone = replace(p, half_angle_deg=angle, direction_inertial=tuple(centre))
                    margin = pair_margin_on_sky(cone, v)
                    levels = [float(margin.min()) - 1.0, 0.0]
                    ax.contourf(ra, dec, margin, levels=levels, colors=[color], alpha=0.22)
            closest.append(f"{t_closest:g}")
            if boresight:
                b = boresight_inertial(run.run.sigma_bn[k : k + 1], p.boresight_body)[0]
                ax.plot(
                    *ra_dec_deg(b),
                    marker="X",
                    markersize=8,
                    color=color,
                    markeredgecolor="black",
                    linestyle="none",
                    zorder=8,
                    gid=f"{p.key}/closest_boresight",
                )
        text = f"{label(p)}, closest at t = {' / '.join(closest)} s" if closest else label(p)
        handles.append(Patch(facecolor=color, edgecolor=color, alpha=0.5, label=text))
    if not pairs:
        return handles
    handles.append(
        Line2D([], [], label=f"moving object's track (every {TRACK_STEP_S:g} s)", **TRACK)
    )
    handles += [
        Line2D([], [], color="0.3", label=f"its cone at the {what}", **CONE_TIMES[tag])
        for tag, what in (
            ("start", "start"),
            ("closest", "closest approach (filled)"),
            ("end", "end"),
        )
    ]
    star: dict[str, Any] = dict(marker="*", color="black", linestyle="none", markersize=9)
    handles.append(
        Line2D([], [], markerfacecolor="white", label="moving object at the start", **star)
    )
    handles.append(Line2D([], [], label="moving object at the end", **star))
    if boresight:
        handles.append(
            Line2D(
                [],
                [],
                marker="X",
                color="0.5",
                markeredgecolor="black",
                linestyle="none",
                markersize=8,
                label="boresight at the closest approach",
            )
        )
    return handles
