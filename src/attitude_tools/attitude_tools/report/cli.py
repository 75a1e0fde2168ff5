"""``attitude-report``: figures, report.html and summary.json of one recorded run, or of
two runs overlaid.

``attitude-report DIR`` reads only ``DIR/bag/`` and writes ``DIR/report/``;
``attitude-report DIR_A DIR_B --out OUT`` writes the comparison to ``OUT/``. The
report is written to a temporary sibling directory and renamed into place when
complete. Exit status: 0 written, 2 bad input (missing or unreadable bag, bad
arguments; nothing is written).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from collections.abc import Sequence

from attitude_tools.output.rundir import OutputDirError, check_replaceable, publish, stage
from attitude_tools.output.strict_json import dump_strict

from .data import BagError, ReportRun, load_run

__all__ = ["main", "write_report", "REPORT_MARKER"]

REPORT_MARKER = "report.html"


def write_report(
    runs: Sequence[ReportRun], out_dir: str, dpi: int = 120, mrp_grid: int = 48
) -> str:
    """Write the report of ``runs`` to ``out_dir`` atomically; return its path.

    An existing ``out_dir`` is replaced only when it holds a previous report.
    """
    from .figures import figures_for, render_figures  # matplotlib: only when writing
    from .html import render_html

    out = check_replaceable(out_dir, (REPORT_MARKER,), "report")
    tmp = stage(out, ".tmp-report-")
    try:
        render_figures(runs, str(tmp), dpi=dpi, mrp_grid=mrp_grid)
        document = {
            "generated_by": "attitude-report",
            "runs": [
                {"label": r.label, "run_dir": r.run_dir, "bag": r.bag_dir, "summary": r.summary}
                for r in runs
            ],
        }
        with open(tmp / "summary.json", "w", encoding="utf-8") as f:
            dump_strict(document, f, indent=2)  # NaN/inf -> null, named in non_finite
        page = render_html(runs, str(tmp), figures_for(runs))
        with open(tmp / REPORT_MARKER, "w", encoding="utf-8") as f:
            f.write(page)
        os.chmod(tmp, 0o755)
        publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return str(out)


def _labels(runs: Sequence[ReportRun], given: Sequence[str] | None) -> None:
    if given:
        for run, label in zip(runs, given, strict=True):
            run.label = label
    elif len(runs) == 2 and runs[0].label == runs[1].label:
        for run in runs:
            run.label = f"{run.label} [{os.path.basename(run.run_dir.rstrip(os.sep))}]"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-report",
        description="Report of a recorded run (figures, report.html, summary.json) from its "
        "bag alone; with two run directories, both runs overlaid.",
    )
    parser.add_argument(
        "runs",
        nargs="+",
        metavar="DIR",
        help="run directory made by attitude-run (reads DIR/bag/ only); give two to compare",
    )
    parser.add_argument(
        "--out", default=None, help="report directory (default DIR/report; required with two runs)"
    )
    parser.add_argument(
        "--labels",
        nargs="+",
        default=None,
        metavar="LABEL",
        help="run labels (default: scenario name and planner variant)",
    )
    parser.add_argument("--dpi", type=int, default=120, help="figure resolution (default 120)")
    parser.add_argument("--quiet", action="store_true", help="do not print the report path")
    args = parser.parse_args(argv)
    if len(args.runs) > 2:
        parser.error("give one run directory, or two to compare")
    if len(args.runs) == 2 and args.out is None:
        parser.error("comparing two runs needs --out OUT")
    if args.labels is not None and len(args.labels) != len(args.runs):
        parser.error(f"--labels needs {len(args.runs)} label(s), one per run directory")
    if not 30 <= args.dpi <= 600:
        parser.error("--dpi must be between 30 and 600")
    t0 = time.perf_counter()
    try:
        runs = [load_run(d) for d in args.runs]
    except BagError as err:
        print(f"attitude-report: error: {err}", file=sys.stderr)
        return 2
    _labels(runs, args.labels)
    out = args.out or os.path.join(args.runs[0], "report")
    try:
        out = write_report(runs, out, dpi=args.dpi)
    except (FileExistsError, NotADirectoryError, PermissionError, OutputDirError) as err:
        print(f"attitude-report: error: {err}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(
            f"attitude-report: wrote {os.path.join(out, REPORT_MARKER)} "
            f"({time.perf_counter() - t0:.1f} s)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
