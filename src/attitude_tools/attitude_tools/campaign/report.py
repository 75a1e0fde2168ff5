"""``DIR/report.html`` of a campaign: one self-contained page (figures as base64 PNG).

Histograms of the body margin, the arrival time and the rotation ratio (variants
overlaid); outcome rates by number of bright objects, of instruments and (when the
campaign draws any) of keep-in cones, per variant; the variants side by side; and the
worst runs with their reproducer files.
"""

from __future__ import annotations

import base64
import io
import os
from html import escape as e
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from .task import FAILURES, OUTCOMES

__all__ = ["write_report"]

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
OUTCOME_COLORS = {
    "reached": "#2ca02c",
    "violated": "#d62728",
    "stuck": "#ff7f0e",
    "infeasible": "#9467bd",
    "blocked": "#8c564b",
    "not_reached": "#7f7f7f",
}
assert set(OUTCOME_COLORS) == set(OUTCOMES), "one colour per outcome of task.OUTCOMES"
CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 0 auto;
       max-width: 1180px; padding: 1.2em 1.6em 3em; color: #1d2125; line-height: 1.4; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.92em; }
th, td { border: 1px solid #d0d4d9; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f5f7; } td.l, th.l { text-align: left; }
img { max-width: 100%; } .bad { color: #b3261e; font-weight: 600; }
"""


def _png(fig: Figure) -> str:
    """The figure as an inline PNG: drawn once (fixed margins, set by its maker; a
    tight bounding box would draw it twice)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return f'<img alt="figure" src="data:image/png;base64,{data}">'


def _histograms(frame: pd.DataFrame) -> str:
    fig, axes = plt.subplots(1, 4, figsize=(18.0, 3.8))
    panels = (
        ("min_margin_deg", "min body constraint margin (deg), all runs", False),
        ("t_reach_s", "arrival time (s), reached runs", True),
        ("rotation_ratio", "rotation flown / eigenaxis angle, reached runs", True),
        ("rotation_to_route", "rotation flown / global route's rotation, reached runs", True),
    )
    for ax, (column, title, reached_only) in zip(axes, panels, strict=True):
        for k, (variant, group) in enumerate(frame.groupby("variant", sort=False)):
            data = group[group["outcome"] == "reached"] if reached_only else group
            values = data[column].to_numpy(dtype=float)
            values = values[np.isfinite(values)]
            if len(values):
                ax.hist(values, bins=30, alpha=0.55, color=COLORS[k % 4], label=str(variant))
        if column == "min_margin_deg":
            ax.axvline(0.0, color="black", linewidth=1.0)
        ax.set_title(title, fontsize=10)
        ax.set_ylabel("runs")
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.subplots_adjust(left=0.04, right=0.99, bottom=0.09, top=0.91, wspace=0.2)
    return _png(fig)


def _rates_by(frame: pd.DataFrame, column: str, label: str) -> str:
    variants = list(dict.fromkeys(frame["variant"]))
    fig, axes = plt.subplots(1, len(variants), figsize=(6.5 * len(variants), 3.6), squeeze=False)
    for ax, variant in zip(axes[0], variants, strict=True):
        group = frame[frame["variant"] == variant]
        table = pd.crosstab(group[column], group["outcome"], normalize="index")
        bottom = np.zeros(len(table))
        for name in OUTCOMES:
            if name in table:
                ax.bar(table.index, table[name], bottom=bottom, color=OUTCOME_COLORS[name],
                       label=name)  # fmt: skip
                bottom += table[name].to_numpy()
        counts = group[column].value_counts().sort_index()
        for x, n in counts.items():
            ax.text(x, 1.01, f"n={n}", ha="center", fontsize=8)
        ax.set_xlabel(label)
        ax.set_ylabel("share of runs")
        ax.set_ylim(0, 1.1)
        ax.set_title(f"{variant}: outcome by {label}", fontsize=10)
    axes[0][-1].legend(loc="lower right", fontsize=8)
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.15, top=0.9, wspace=0.22)
    return _png(fig)


def _keep_in_rates(frame: pd.DataFrame) -> list[str]:
    """The outcome by number of keep-in cones, for a campaign that has any."""
    if "n_keep_in" not in frame or not (frame["n_keep_in"].fillna(0) > 0).any():
        return []
    return [
        "<h2>Outcome by number of keep-in cones</h2>",
        _rates_by(frame, "n_keep_in", "keep-in cones"),
    ]


def _variants_table(summary: dict[str, Any]) -> str:
    variants = summary["variants"]
    head = "".join(f"<th>{e(v)}</th>" for v in variants)
    rows = []
    for name in OUTCOMES:
        cells = []
        for v in variants.values():
            o = v["outcomes"][name]
            lo, hi = o["wilson95"]
            cells.append(f"<td>{o['count']} ({100 * o['rate']:.1f} %, "
                         f"95 % CI {100 * lo:.1f}-{100 * hi:.1f})</td>")  # fmt: skip
        rows.append(f"<tr><th class=l>{name}</th>{''.join(cells)}</tr>")
    for key, what in (("rotation_ratio", "rotation ratio"), ("t_reach_s", "arrival, s"),
                      ("min_margin_deg", "min margin, deg")):  # fmt: skip
        for p in ("p50", "p90", "p99"):
            cells = []
            for v in variants.values():
                x = v[key][p]
                cells.append(f"<td>{'-' if x is None else f'{x:.3f}'}</td>")
            rows.append(f"<tr><th class=l>{what} {p}</th>{''.join(cells)}</tr>")
    return f"<table><tr><th class=l>outcome</th>{head}</tr>{''.join(rows)}</table>"


def _worst_table(worst: pd.DataFrame) -> str:
    cols = ("run", "variant", "outcome", "min_margin_deg", "rotation_ratio", "t_reach_s",
            "eigenaxis_deg", "n_instruments", "n_objects")  # fmt: skip
    head = "".join(f"<th>{c}</th>" for c in cols) + "<th class=l>reproducer</th>"
    rows = []
    for _, r in worst.iterrows():
        cells = []
        for c in cols:
            v = r[c]
            text = f"{v:.3f}" if isinstance(v, float) else str(v)
            bad = c == "outcome" and v != "reached"
            cells.append(f"<td{' class=bad' if bad else ''}>{e(text)}</td>")
        link = f"reproducers/run_{int(r['run'])}_{r['variant']}.yaml"
        cells.append(f'<td class=l><a href="{e(link)}">{e(link)}</a></td>')
        rows.append(f"<tr>{''.join(cells)}</tr>")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def write_report(path: str | os.PathLike[str], frame: pd.DataFrame, summary: dict[str, Any],
                 worst: pd.DataFrame, info: dict[str, Any]) -> None:  # fmt: skip
    """Write the page to ``path``."""
    title = f"Campaign {info['name']}: {info['runs']} runs x {len(info['variants'])} variant(s)"
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>{e(title)}</title><style>{CSS}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        f"<p>SPEC {e(info['spec'])}, seed {info['seed']}, base scenario "
        f"{e(info['base_scenario'])}; {info['tasks']} tasks; wall time "
        f"{info['wall_time_s']:.1f} s on {e(str(info['engine']))}.</p>",
        "<h2>Variants side by side</h2>",
        _variants_table(summary),
        "<h2>Distributions</h2>",
        _histograms(frame),
        "<h2>Outcome by number of bright objects</h2>",
        _rates_by(frame, "n_objects", "bright objects"),
        "<h2>Outcome by number of instruments</h2>",
        _rates_by(frame, "n_instruments", "instruments"),
        *_keep_in_rates(frame),
        f"<h2>The {len(worst)} worst runs</h2>",
        f"<p>Failures first ({', '.join(FAILURES)}), then the lowest "
        "body margin, then the highest rotation ratio. Each reproducer is a complete "
        "scenario file for <code>attitude-offline</code> or <code>attitude-run</code>.</p>",
        _worst_table(worst),
        "</body></html>",
    ]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(parts))
