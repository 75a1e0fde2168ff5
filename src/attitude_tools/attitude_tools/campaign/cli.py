"""``attitude-campaign SPEC.yaml --out DIR [--workers N | --scheduler ADDR] [--resume]``.

Runs every ``(run, variant)`` of a SPEC (:mod:`.spec`) through the offline closed loop
(:func:`.task.run_task`), a few consecutive short runs per Dask task
(:func:`.task.batches`), on a ``LocalCluster`` of ``--workers`` processes (default: one
per core) or on a running cluster (``--scheduler tcp://HOST:PORT``, started with
``dask scheduler`` and ``dask worker``). Results are written as they complete
(``DIR/parts/``, :mod:`.store`); a worker that dies has its tasks retried elsewhere.
SIGINT (or SIGTERM) stops the campaign with what completed on disk; ``--resume``
continues it. At the end: ``DIR/runs.parquet``, ``DIR/summary.json``,
``DIR/report.html`` and ``DIR/reproducers/run_<i>_<variant>.yaml`` for the worst runs.

Exit codes: 0 complete, 1 a task failed, 2 bad input (SPEC, ``--out``, scheduler),
130 interrupted.

What only this driver needs (pandas, pyarrow, matplotlib: the table, the statistics,
the report) is imported when used, not with this module: a worker process started by
``multiprocessing``'s spawn imports the main module again (the ``attitude-campaign``
script, so this one), and never uses them. The driver loads them in a thread while its
cluster starts, and writes its outputs while the cluster closes.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, TextIO

from attitude_tools.output.strict_json import dump_strict

from .progress import Progress
from .spec import CampaignSpec, SpecError, load_spec
from .task import TIMING_COLUMNS, batches, reproducer, run_tasks

if TYPE_CHECKING:
    from distributed import Client

    from .store import PartWriter

__all__ = ["main", "run_campaign", "CONNECT_TIMEOUT_S", "WORST"]

CONNECT_TIMEOUT_S = 8.0  # a scheduler that does not answer: an error within 10 s
WORST = 20
FLUSH_S = 1.0  # completed rows reach disk within this wall time
SPEC_COPY = "spec.yaml"


class CampaignError(Exception):
    """Bad input found after the SPEC was read (exit 2)."""


def _json_ready(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(v) for v in value]
    return value


_TRIM_KEY = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"
"""Dask's nanny sets ``MALLOC_TRIM_THRESHOLD_=65536`` in its workers (to hand freed
memory back), which also turns off glibc's adaptive mmap threshold: every NumPy
temporary over 128 kB is then mapped and unmapped afresh, and its pages faulted in
again, 1.5 ms of a 150 s run's 3 ms of metrics. A campaign worker holds a few result
rows, nothing to hand back: the LocalCluster's workers keep glibc's defaults (or the
caller's own ``MALLOC_TRIM_THRESHOLD_``)."""


def _connect(workers: int | None, scheduler: str | None) -> tuple[Client, str]:
    import dask
    from distributed import Client, LocalCluster

    # The driver's own modules load while the workers start (the main thread waits).
    threading.Thread(target=_preload_driver_modules).start()
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")  # type: ignore[no-untyped-call]
            return client, f"scheduler {scheduler}"
        except (OSError, TimeoutError, ValueError) as exc:
            raise CampaignError(
                f"--scheduler {scheduler}: no Dask scheduler answered within "
                f"{CONNECT_TIMEOUT_S:g} s ({exc})"
            ) from exc
    n = workers or os.cpu_count() or 1
    with dask.config.set({_TRIM_KEY: None}):
        cluster = LocalCluster(  # type: ignore[no-untyped-call]
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.CRITICAL,  # worker shutdown chatter is not the user's concern
        )
    client = Client(cluster)  # type: ignore[no-untyped-call]
    return client, f"LocalCluster of {n} worker process(es)"


def _prepare_out(spec: CampaignSpec, out: Path, resume: bool) -> None:
    text = Path(spec.source).read_text(encoding="utf-8")
    if out.exists() and not out.is_dir():
        raise CampaignError(f"--out {out}: exists and is not a directory")
    if out.exists() and any(out.iterdir()):
        copy = out / SPEC_COPY
        if not resume:
            what = "a campaign" if copy.exists() else "not a campaign"
            raise CampaignError(
                f"--out {out}: exists ({what}); give --resume to continue a campaign, "
                "or another directory"
            )
        if not copy.exists():
            raise CampaignError(f"--out {out}: --resume, but it holds no campaign")
        if copy.read_text(encoding="utf-8") != text:
            raise CampaignError(
                f"--out {out}: --resume with another SPEC than the campaign's ({copy})"
            )


def _preload_driver_modules() -> None:
    """Import what the driver alone uses (pandas, pyarrow, matplotlib), meant for a
    thread while the cluster starts (the main thread then mostly waits for it)."""
    from . import report, stats, store  # noqa: F401


def _finish(
    spec: CampaignSpec, out: Path, info: dict[str, Any], log: Callable[[str], None]
) -> dict[str, Any]:
    from .stats import summarize_campaign, worst_runs
    from .store import read_parts, write_table

    frame = read_parts(out)
    write_table(frame, out / "runs.parquet")
    summary: dict[str, Any] = summarize_campaign(frame) | {"campaign": info}
    worst = worst_runs(frame, WORST)
    repro = out / "reproducers"
    tmp = out / ".reproducers.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    for _, row in worst.iterrows():
        i, variant = int(row["run"]), str(row["variant"])
        (tmp / f"run_{i}_{variant}.yaml").write_text(reproducer(spec, i, variant))
    shutil.rmtree(repro, ignore_errors=True)
    os.replace(tmp, repro)
    summary["worst_runs"] = [
        {k: row[k] for k in ("run", "variant", "outcome", "min_margin_deg", "rotation_ratio")}
        for _, row in worst.iterrows()
    ]
    with open(out / "summary.json.tmp", "w") as f:
        dump_strict(summary, f, indent=2)  # NaN/inf -> null, named in non_finite
    summary = _json_ready(summary)
    os.replace(out / "summary.json.tmp", out / "summary.json")
    from .report import write_report

    write_report(out / "report.html.tmp", frame, summary, worst, info)
    os.replace(out / "report.html.tmp", out / "report.html")
    table, report = out / "runs.parquet", out / "report.html"
    log(f"attitude-campaign: {len(frame)} rows in {table}; report {report}")
    for variant, v in summary["variants"].items():
        counts = ", ".join(f"{k} {o['count']}" for k, o in v["outcomes"].items() if o["count"])
        log(f"  {variant}: {counts}")
        check = v.get("blocked_goal")
        if check and (check["covered"] or check["never_covered"]):
            log(
                f"    blocked: the goal covered during the run in {check['covered']}, "
                f"never covered in {check['never_covered']}"
            )
    return summary


def run_campaign(
    spec: CampaignSpec,
    out: Path,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    log: Callable[[str], None] = print,
    progress_stream: TextIO = sys.stderr,
) -> int:
    """The campaign (see the module docstring); returns the exit code."""
    _prepare_out(spec, out, resume)
    client, engine = _connect(workers, scheduler)
    t0 = time.monotonic()
    try:
        from .store import PartWriter, done_tasks  # loaded by now (_connect's thread)

        out.mkdir(parents=True, exist_ok=True)
        if not (out / SPEC_COPY).exists():
            shutil.copyfile(spec.source, out / SPEC_COPY)
        done = done_tasks(out)
        todo = [t for t in spec.tasks if t not in done]
        log(
            f"attitude-campaign: {spec.name}: {len(spec.tasks)} tasks, {len(done)} done, "
            f"{len(todo)} to run on {engine}"
        )
        writer = PartWriter(out)
        progress = Progress(len(spec.tasks), len(done), progress_stream)
        t_tasks = time.monotonic()
        interrupted = _run_tasks(client, spec, todo, writer, progress)
        tasks_wall = time.monotonic() - t_tasks
        progress.close()
    except BaseException:
        _close(client)
        raise
    if interrupted:
        _close(client)
        left = len(spec.tasks) - len(done_tasks(out))
        log(f"attitude-campaign: interrupted; {left} task(s) left: --resume continues")
        return 130
    info = {
        "name": spec.name,
        "spec": spec.source,
        "seed": spec.seed,
        "runs": spec.runs,
        "variants": list(spec.planner_variants),
        "base_scenario": spec.base_scenario,
        "tasks": len(spec.tasks),
        "engine": engine,
        "wall_time_s": time.monotonic() - t0,  # connected to the last result (this run)
        "tasks_wall_s": tasks_wall,  # from the first submission to the last result
        "resumed": bool(done),
        "timing_columns": list(TIMING_COLUMNS),
    }
    closing = _Closing(client)  # the workers stop while the outputs are written
    try:
        _finish(spec, out, info, log)
    except BaseException:
        closing.thread.join()
        raise
    closing.wait()
    return 0


class _Closing:
    """:func:`_close` in a thread; :meth:`wait` joins it and raises what it raised."""

    def __init__(self, client: Client) -> None:
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, args=(client,), daemon=True)
        self.thread.start()

    def _run(self, client: Client) -> None:
        try:
            _close(client)
        except BaseException as exc:  # noqa: BLE001 (re-raised by wait(), in the caller's thread)
            self.error = exc

    def wait(self) -> None:
        self.thread.join()
        if self.error is not None:
            raise self.error


def _run_tasks(
    client: Client,
    spec: CampaignSpec,
    todo: list[tuple[int, str]],
    writer: PartWriter,
    progress: Progress,
) -> bool:
    """Run ``todo``; True when interrupted. Rows reach disk within :data:`FLUSH_S`."""
    from distributed import as_completed

    if not todo:
        return False
    groups = batches(spec, todo, sum(client.nthreads().values()))  # type: ignore[no-untyped-call]
    keys = [
        f"attitude-campaign-{spec.name}-{spec.seed}-{g[0][0]}-{g[0][1]}"
        + (f"+{len(g) - 1}" if len(g) > 1 else "")
        for g in groups
    ]
    futures = client.map(run_tasks, [spec] * len(groups), groups, key=keys, pure=False, retries=2)
    buffer: list[dict[str, Any]] = []
    flushed = time.monotonic()
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        for future in as_completed(futures):  # type: ignore[no-untyped-call]
            rows = future.result()  # a task that failed its retries raises here
            buffer += rows
            for row in rows:
                progress.update(row["outcome"])
            if time.monotonic() - flushed >= FLUSH_S:
                writer.write(buffer)
                buffer, flushed = [], time.monotonic()
    except KeyboardInterrupt:
        writer.write(buffer)
        client.cancel(futures)  # type: ignore[no-untyped-call]
        return True
    finally:
        signal.signal(signal.SIGTERM, previous)
    writer.write(buffer)
    return False


def _raise_interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def _close(client: Client) -> None:
    cluster = getattr(client, "cluster", None)
    try:
        client.close(timeout=10)  # type: ignore[no-untyped-call]
    finally:
        if cluster is not None:
            cluster.close(timeout=10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-campaign",
        description="Monte Carlo campaign of dispersed slews on Dask (docs/campaigns.md).",
    )
    parser.add_argument("spec", help="campaign SPEC file (YAML)")
    parser.add_argument("--out", required=True, help="campaign directory to create")
    engine = parser.add_mutually_exclusive_group()
    engine.add_argument(
        "--workers", type=int, default=None,
        help="LocalCluster worker processes (default: the number of cores)",
    )  # fmt: skip
    engine.add_argument(
        "--scheduler", default=None, metavar="tcp://HOST:PORT",
        help="a running Dask scheduler (dask scheduler / dask worker) instead",
    )  # fmt: skip
    parser.add_argument("--resume", action="store_true", help="continue a campaign in --out")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    args = parser.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers: must be >= 1, got {args.workers}")

    def log(msg: str) -> None:
        if not args.quiet:
            print(msg, flush=True)

    try:
        spec = load_spec(args.spec)
        return run_campaign(
            spec,
            Path(args.out).resolve(),
            workers=args.workers,
            scheduler=args.scheduler,
            resume=args.resume,
            log=log,
        )
    except (SpecError, CampaignError) as exc:
        print(f"attitude-campaign: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("attitude-campaign: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
