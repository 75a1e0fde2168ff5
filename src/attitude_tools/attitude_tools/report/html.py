"""``report.html``: one self-contained page (inline CSS, figures as base64 data URIs, no
external links) with the runs' scenarios, the summary table (one column per run) and
the figures. ``ROWS`` is the table; every cell shows ``format_value`` of one
summary number and carries its exact JSON value in ``data-value``.

Where a scenario has them, the scenario table also shows each object's motion (ephemeris
body or turning rate), the epoch and orbit, and each instrument's per-object exclusions
and the objects it does not avoid; on a moving sky the captions say how the figures show
it (``MOVING_SKY_CAPTIONS``). The paper's static skies are shown as before.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario

from .data import PAIR_KEY, SUMMARY_KEYS, ReportRun

__all__ = ["ROWS", "MOVING_SKY_CAPTIONS", "format_value", "table_rows", "render_html"]

# (summary key, row label, unit); the per-pair minima go where PAIR_KEY stands.
ROWS = (
    ("scenario", "scenario", ""),
    ("planner_variant", "planner variant", ""),
    ("time_mode", "time mode", ""),
    ("reached", "reached the goal (arrival tolerances)", ""),
    ("t_reach_s", "arrival time", "s"),
    ("t_plan_arrival_s", "planner arrival time", "s"),
    ("planner_stuck", "planner stuck", ""),
    ("min_margin_deg", "minimum margin, all constraints (between steps too)", "deg"),
    ("t_min_margin_s", "time of the minimum margin", "s"),
    (PAIR_KEY, "minimum margin at the samples", "deg"),
    ("path_length_mrp", "path length, body sigma_BN", "MRP"),
    ("target_path_length_mrp", "path length, target sigma_t", "MRP"),
    ("peak_torque_nm", "peak torque |u|", "N m"),
    ("peak_rate_rad_s", "peak rate |omega|", "rad/s"),
    ("rotation_deg", "rotation flown to the arrival", "deg"),
    ("time_bound_s", "rest-to-rest time bound T* with the actuator limits", "s"),
    ("time_ratio_to_bound", "arrival time / T*", ""),
    ("peak_torque_to_bound", "peak |u_i| / max_torque_nm_i", ""),
    ("peak_rate_to_bound", "peak |omega| / max_rate_rad_s", ""),
    ("final_rate_rad_s", "final rate |omega|", "rad/s"),
    ("final_attitude_error_deg", "final attitude error", "deg"),
    ("faults", "faults (start to end, shaded on the figures' timelines)", "s"),
    ("knowledge_3sigma_deg", "knowledge 3-sigma the guidance planned with (sensors)", "deg"),
    ("estimation_error_deg_p99", "estimate against truth, attitude error p99 (sensors)", "deg"),
    ("planner_step_us_median", "planner step time, median (/diagnostics)", "us"),
    ("planner_step_us_p99", "planner step time, p99 (/diagnostics)", "us"),
    ("steps_recorded", "steps recorded", ""),
    ("steps_per_s", "steps per wall-clock second (after the loop's first answer)", "1/s"),
    ("sim_time_s", "scenario time limit", "s"),
    ("dt_s", "time step", "s"),
)
assert {k for k, _, _ in ROWS} == set(SUMMARY_KEYS)

_MOVING_CONES = (
    " On a moving sky, each moving object is drawn as its track over the run (every 1 s) "
    "with its keep-out cone for each instrument that avoids it (the exclusion from its "
    "limb plus its angular radius at that time) at the start (dotted), at the closest "
    "approach (solid, filled: the time of the pair's smallest margin) and at the end "
    "(dashed)."
)
MOVING_SKY_CAPTIONS = {  # added to the figures' captions when a run's sky moves
    "keepout_inertial.png": _MOVING_CONES,
    "keepout_mrp.png": " On a moving sky, the regions of the sky at t = 0.",
    "trajectory_mrp.png": " On a moving sky, the regions of the sky at t = 0.",
    "trajectory_boresight.png": _MOVING_CONES
    + " The boresight at each closest approach is marked with a cross.",
    "margin.png": " On a moving sky, each margin is against the sky of its instant (the "
    "object's direction and angular radius then, the exclusion measured from its limb), "
    "one line per constraint, labelled with its name.",
}

CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 0 auto;
       max-width: 1180px; padding: 1.2em 1.6em 3em; color: #1d2125; line-height: 1.4; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { font-size: 1.2em; margin-top: 1.8em; border-bottom: 1px solid #d0d4d9; padding-bottom: 0.2em; }
h3 { font-size: 1.05em; margin: 1.4em 0 0.3em; }
p.note { color: #555e68; font-size: 0.92em; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.93em; }
th, td { border: 1px solid #d0d4d9; padding: 0.3em 0.7em; text-align: left; vertical-align: top; }
thead th { background: #eef1f4; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td.unit { color: #555e68; white-space: nowrap; }
td.bad { background: #fde8e8; color: #9b1c1c; font-weight: 600; }
td.good { color: #1e6b34; }
tr.pair th { font-weight: normal; padding-left: 1.6em; }
figure { margin: 0.4em 0 1.6em; }
figure img { max-width: 100%; height: auto; border: 1px solid #e3e6ea; }
figcaption { color: #555e68; font-size: 0.9em; margin-top: 0.3em; }
code { font-size: 0.92em; }
"""


def format_value(value: Any) -> str:
    """How a summary number is shown: 4 significant digits, yes/no, n/a for missing."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return format(value, ".4g")
    if isinstance(value, list):  # the faults: kind, start to end
        if not value:
            return "none"
        return "; ".join(
            f"{f['kind']} {f['t_start_s']:.4g} to "
            + ("the end" if f["t_end_s"] is None else f"{f['t_end_s']:.4g}")
            for f in value
        )
    return str(value)


def table_rows(summaries: Sequence[dict[str, Any]]) -> list[tuple[str, str, str, list[Any]]]:
    """(key path, label, unit, values per run) of the summary table, pairs expanded."""
    rows: list[tuple[str, str, str, list[Any]]] = []
    for key, label, unit in ROWS:
        if key != PAIR_KEY:
            rows.append((key, label, unit, [s.get(key) for s in summaries]))
            continue
        pairs: list[str] = []
        for s in summaries:
            pairs += [p for p in s.get(PAIR_KEY, {}) if p not in pairs]
        for p in pairs:
            rows.append(
                (
                    f"{PAIR_KEY}/{p}",
                    f"{label}, {p}",
                    unit,
                    [s.get(PAIR_KEY, {}).get(p) for s in summaries],
                )
            )
    return rows


def _cell(key: str, value: Any) -> str:
    classes = ["num"] if isinstance(value, (int, float)) and not isinstance(value, bool) else []
    if key.startswith("min_margin_deg") and isinstance(value, float):
        classes.append("bad" if value <= 0.0 else "good")
    if key == "reached" and value is not None:
        classes.append("good" if value else "bad")
    if key in ("planner_stuck", "faults") and value:
        classes.append("bad")
    attr = f' class="{" ".join(classes)}"' if classes else ""
    exact = html.escape(json.dumps(value), quote=True)
    return (
        f'<td{attr} data-key="{html.escape(key, quote=True)}" data-value="{exact}" '
        f'title="{exact}">{html.escape(format_value(value))}</td>'
    )


def _vec(v: npt.ArrayLike) -> str:
    return "[" + ", ".join(f"{x:.4g}" for x in np.asarray(v, dtype=float)) + "]"


def _paper_instrument(sc: Scenario, i: int) -> bool:
    """An instrument with one half-angle for every object (the paper's)."""
    inst = sc.instruments[i]
    return (
        inst.half_angle_deg is not None
        and not inst.exclusion_deg
        and inst.avoids == sc.bright_object_names
    )


def _instrument_cell(sc: Scenario, i: int) -> str:
    """Name, boresight and half-angle; the exclusion of each object it avoids (from the
    limb of a body with a radius) where they differ from the paper's."""
    e = html.escape
    text = f"{e(sc.instrument_names[i])}: {_vec(sc.boresights_body[i])}"
    if not math.isnan(sc.half_angles_deg[i]):
        text += f", {sc.half_angles_deg[i]:g} deg"
    if _paper_instrument(sc, i):
        return text
    inst = sc.instruments[i]
    bodies = {o.name for o in sc.bright_objects if o.ephemeris is not None}
    per = ", ".join(
        f"{e(o)} {inst.exclusion_of(o):g} deg" + (" from the limb" if o in bodies else "")
        for o in inst.avoids
    )
    text += f"; keep-out: {per or 'none'}"
    ignored = [o for o in sc.bright_object_names if o not in inst.avoids]
    return text + (f"; does not avoid {e(', '.join(ignored))}" if ignored else "")


def _object_cell(sc: Scenario, j: int) -> str:
    """Name and direction; an ephemeris body's kind or a turning direction's rate."""
    e = html.escape
    o = sc.bright_objects[j]
    text = f"{e(o.name)}: {_vec(sc.directions_inertial[j])}"
    if o.ephemeris is not None:
        radius = float(sc.sky.object_directions(0.0)[1][j])
        return (
            f"{e(o.name)}: {e(o.ephemeris)} (ephemeris, seen from the spacecraft), "
            f"{_vec(sc.directions_inertial[j])} at t = 0, angular radius {radius:.3g} deg"
        )
    if o.motion.moves:
        rate = np.asarray(o.rate_inertial_rad_s, dtype=float)
        size = float(np.linalg.norm(rate))
        return (
            f"{text} at t = 0, turning at {math.degrees(size):.3g} deg/s "
            f"about {_vec(rate / size)} (inertial)"
        )
    return text


def _epoch_cell(sc: Scenario) -> str:
    if sc.epoch_utc is None:
        return "none"
    text = html.escape(sc.epoch_utc)
    o = sc.orbit
    if o is None:
        return text + "; no orbit (the Sun and Moon seen from the Earth's centre)"
    return (
        f"{text}; orbit a {o.semi_major_axis_km:g} km, e {o.eccentricity:g}, "
        f"i {o.inclination_deg:g} deg, RAAN {o.raan_deg:g} deg, "
        f"arg. of perigee {o.arg_perigee_deg:g} deg, true anomaly {o.true_anomaly_deg:g} deg"
    )


def _keep_in_direction(sc: Scenario, k: int) -> str:
    d = _vec(sc.keep_in_directions_inertial[k])
    body = sc.keep_in[k].ephemeris
    return d if body is None else f"{d} ({html.escape(body)} at t = 0)"


def _scenario_table(runs: Sequence[ReportRun]) -> str:
    e = html.escape
    head = "".join(f"<th>{e(r.label)}</th>" for r in runs)
    paper = all(
        _paper_instrument(r.scenario, i) for r in runs for i in range(len(r.scenario.instruments))
    )
    static = all(r.scenario.sky.static for r in runs)
    rows = [
        ("run directory", [f"<code>{e(r.run_dir)}</code>" for r in runs]),
        ("bag (the only input)", [f"<code>{e(r.bag_dir)}</code>" for r in runs]),
        (
            "instruments: boresight (body), half-angle"
            + ("" if paper else "; keep-out angle of each object avoided"),
            [
                "<br>".join(
                    _instrument_cell(r.scenario, i) for i in range(len(r.scenario.instruments))
                )
                for r in runs
            ],
        ),
        (
            "bright objects: direction (inertial)" + ("" if static else ", motion"),
            [
                "<br>".join(
                    _object_cell(r.scenario, j) for j in range(len(r.scenario.bright_objects))
                )
                for r in runs
            ],
        ),
        ("epoch (UTC), orbit", [_epoch_cell(r.scenario) for r in runs]),
        (
            "keep-in cones: axis (body), direction (inertial), largest angle",
            [
                "<br>".join(
                    f"{e(n)}: {_vec(a)}, {_keep_in_direction(r.scenario, k)}, {g:g} deg"
                    for k, (n, a, g) in enumerate(
                        zip(
                            r.scenario.keep_in_names,
                            r.scenario.keep_in_axes_body,
                            r.scenario.keep_in_max_angles_deg,
                            strict=True,
                        )
                    )
                )
                or "none"
                for r in runs
            ],
        ),
        (
            "initial / desired MRP",
            [f"{_vec(r.scenario.initial_mrp)} / {_vec(r.scenario.desired_mrp)}" for r in runs],
        ),
        (
            "arrival tolerances",
            [
                f"{r.scenario.arrival.attitude_tol_deg:g} deg, "
                f"{r.scenario.arrival.rate_tol_rad_s:g} rad/s"
                for r in runs
            ],
        ),
    ]
    if not any(r.scenario.keep_in_names for r in runs):  # the row only where it says something
        rows = [row for row in rows if not row[0].startswith("keep-in cones")]
    if not any(r.scenario.epoch_utc for r in runs):
        rows = [row for row in rows if not row[0].startswith("epoch")]
    body = "".join(
        f"<tr><th>{e(name)}</th>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>"
        for name, cells in rows
    )
    return f"<table><thead><tr><th></th>{head}</tr></thead><tbody>{body}</tbody></table>"


def _summary_table(runs: Sequence[ReportRun]) -> str:
    e = html.escape
    head = "".join(f"<th>{e(r.label)}</th>" for r in runs)
    body = []
    for key, label, unit, values in table_rows([r.summary for r in runs]):
        cls = ' class="pair"' if key.startswith(PAIR_KEY + "/") else ""
        body.append(
            f"<tr{cls}><th>{e(label)}</th><td class=\"unit\">{e(unit)}</td>"
            + "".join(_cell(key, v) for v in values)
            + "</tr>"
        )
    return (
        f'<table id="summary"><thead><tr><th>quantity</th><th>unit</th>{head}</tr></thead>'
        f"<tbody>{''.join(body)}</tbody></table>"
    )


_GOAL_COLUMNS = (
    ("name", "goal", ""),
    ("outcome", "outcome", ""),
    ("t_commanded_s", "commanded", "s"),
    ("t_start_s", "in force from", "s"),
    ("t_reach_s", "arrival", "s"),
    ("t_end_s", "ended", "s"),
    ("rotation_deg", "rotation to it", "deg"),
    ("min_margin_deg", "min margin in force (dense, body)", "deg"),
    ("reason", "reason", ""),
)


def _goals_section(runs: Sequence[ReportRun]) -> list[str]:
    """One table per run with goals (``summary.json`` ``goals``): each goal, its
    outcome, its times, its rotation, its smallest margin and the reason of a refusal;
    nothing for runs without goals."""
    e = html.escape
    parts: list[str] = []
    for run in runs:
        goals = run.summary.get("goals") or []
        if not goals:
            continue
        head = "".join(
            f"<th>{e(label)}" + (f" ({e(unit)})" if unit else "") + "</th>"
            for _, label, unit in _GOAL_COLUMNS
        )
        rows = []
        for goal in goals:
            cells = []
            for key, _, unit in _GOAL_COLUMNS:
                value = goal.get(key)
                bad = (key == "outcome" and value not in ("reached", "refused")) or (
                    key == "min_margin_deg" and value is not None and value <= 0.0
                )
                cls = "num" if unit else ""
                cls += " bad" if bad else ""
                text = "" if value is None else format_value(value) if unit else str(value)
                cells.append(f'<td class="{cls.strip()}">{e(text)}</td>')
            rows.append("<tr>" + "".join(cells) + "</tr>")
        parts += [
            f"<h3>{e(run.label)}</h3>",
            f'<table class="goals"><thead><tr>{head}</tr></thead>'
            f"<tbody>{''.join(rows)}</tbody></table>",
        ]
    if parts:
        parts = [
            "<h2>Goals</h2>",
            '<p class="note">The plan\'s targets and the goals received on '
            "<code>&lt;run namespace&gt;/planner/goal</code>, in order, from the planner's "
            "reports in the bag (times from the first recorded step); the margin is the "
            "body's, densely, while the goal was in force. Figure <code>goals.png</code> "
            "shows each goal's path and margins.</p>",
            *parts,
        ]
    return parts


def render_html(
    runs: Sequence[ReportRun], figure_dir: str, figures: Mapping[str, tuple[str, str]]
) -> str:
    """The page for ``runs`` with the PNGs of ``figures`` (file -> (title, caption))
    read from ``figure_dir`` and embedded."""
    e = html.escape
    moving = not all(r.scenario.sky.static for r in runs)
    if len(runs) == 1:
        title = f"Attitude run report: {runs[0].label}"
    else:
        title = "Attitude run comparison: " + " vs ".join(r.label for r in runs)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{e(title)}</title><style>{CSS}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        '<p class="note">Every number and figure is computed from the recorded bag alone '
        "(the run rebuilt from its messages and the scenario attached to the bag), with the "
        "same <code>summarize</code> as <code>attitude-run</code>'s summary.json.</p>",
        "<h2>Scenario</h2>",
        _scenario_table(runs),
        "<h2>Summary</h2>",
        _summary_table(runs),
        '<p class="note">Margins are the angle between boresight and object minus the '
        "cone half-angle for a keep-out pair (instrument/object), the largest angle allowed "
        "minus the angle between axis and direction for a keep-in cone (keep_in/name); "
        "positive is safe. Arrival time: first time after which the body stays within the "
        "arrival tolerances."
        + (
            " On a moving sky, a keep-out margin is the angle between the boresight and the "
            "object's direction at that instant minus the exclusion (from the object's limb) "
            "and the object's angular radius then."
            if moving
            else ""
        )
        + "</p>",
        *_goals_section(runs),
        "<h2>Figures</h2>",
    ]
    for name, (fig_title, caption) in figures.items():
        if moving:
            caption += MOVING_SKY_CAPTIONS.get(name, "")
        with open(os.path.join(figure_dir, name), "rb") as f:
            data = base64.b64encode(f.read()).decode("ascii")
        parts.append(
            f'<figure id="{e(name, quote=True)}"><h3>{e(fig_title)}</h3>'
            f'<img alt="{e(fig_title, quote=True)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{e(caption)} (<code>{e(name)}</code>)</figcaption></figure>"
        )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
