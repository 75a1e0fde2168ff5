"""Staging directories left by an ``attitude-run`` that died (SIGKILL, power loss).

The next ``attitude-run`` into the same ``--out`` calls :func:`salvage_stale_runs`
before it stages its own run. Each staging directory of that ``--out`` whose owner no
longer runs (:func:`attitude_tools.output.rundir.stale_stages`) is

* **recovered** when its bag, finished by the recorder or by
  :func:`attitude_tools.bag.recovery.recover_bag` (an unfinished one), holds at least
  one complete step: its ``summary.json`` is built from the bag (``interrupted: true``,
  ``failure`` naming the lost owner, ``bag_recovered`` whether the bag had to be
  finished) and the directory is published as ``<out>.interrupted-<UTC start>``
  beside ``--out``;
* **kept** the same way, without a summary, when its bag has data but cannot be
  recovered or holds no complete step;
* **cleaned** (removed) when there is no recording in it.

Each outcome is one line naming both directories. A live run's staging directory is
never touched.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from attitude_core.config.scenario import ScenarioError
from attitude_core.runtime.process_identity import ProcessIdentity
from attitude_tools.bag.recovery import recover_bag
from attitude_tools.output.rundir import OWNER_FILE, publish, stale_stages
from attitude_tools.output.strict_json import dump_strict

__all__ = ["salvage_stale_runs", "interrupted_name"]


def interrupted_name(out: Path, started_utc: str) -> Path:
    """``<out>.interrupted-<UTC start, compact>`` beside ``out``, made unique."""
    stamp = started_utc.replace("-", "").replace(":", "")
    path = out.parent / f"{out.name}.interrupted-{stamp}"
    n = 1
    while path.exists():
        n += 1
        path = out.parent / f"{out.name}.interrupted-{stamp}-{n}"
    return path


def _has_data(bag: Path) -> bool:
    return any(p.stat().st_size > 0 for p in bag.glob("*.mcap"))


def _salvage(stale: Path, out: Path) -> str:
    from attitude_tools.bag.run_record import run_from_bag, summarize_bag  # rarely needed

    record = json.loads((stale / OWNER_FILE).read_text())
    owner = ProcessIdentity.decode(record["owner"])
    lost = f"attitude-run (pid {owner.pid}, started {record['started_utc']}) died before finishing"
    bag = stale / "bag"
    if not (bag.is_dir() and _has_data(bag)):
        shutil.rmtree(stale)
        return f"cleaned stale staging directory {stale} (no recording): {lost}"
    dest = interrupted_name(out, record["started_utc"])
    try:
        recovery = recover_bag(str(bag))  # a finished bag is left unchanged
        summary = summarize_bag(run_from_bag(str(bag)))
    except (ValueError, OSError, KeyError, ScenarioError) as err:
        publish(stale, dest)
        return f"kept stale staging directory {stale} as {dest}, not summarized ({err}): {lost}"
    summary.update(
        {
            "interrupted": True,
            "bag_recovered": recovery.recovered,
            "end_reason": "interrupted",
            "failure": lost,
        }
    )
    with open(stale / "summary.json", "w") as f:
        dump_strict(summary, f, indent=2)
    publish(stale, dest)
    steps = summary["steps_recorded"]
    return f"recovered stale staging directory {stale} as {dest} ({steps} steps): {lost}"


def salvage_stale_runs(out: Path, prefix: str) -> list[str]:
    """Recover, keep or clean each stale staging directory of ``out``; one line each."""
    lines = []
    for stale in stale_stages(out, prefix):
        try:
            lines.append(_salvage(stale, out))
        except (OSError, ValueError, KeyError) as err:  # e.g. another run took it first
            lines.append(f"could not salvage stale staging directory {stale}: {err}")
    return lines
