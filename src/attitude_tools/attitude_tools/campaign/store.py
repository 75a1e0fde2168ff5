"""Campaign results on disk: Parquet parts written as runs complete, one table at the end.

``DIR/parts/part-<n>.parquet`` holds a batch of completed rows, each part written to a
temporary name and renamed, so a part is whole or absent whatever kills the campaign.
``--resume`` reads the parts back to skip the completed ``(run, variant)`` pairs.
``DIR/runs.parquet`` is every part, sorted by run and variant.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

__all__ = ["PartWriter", "read_parts", "write_table", "done_tasks"]


class PartWriter:
    """Appends batches of rows as new part files."""

    def __init__(self, out_dir: Path) -> None:
        self.dir = out_dir / "parts"
        self.dir.mkdir(parents=True, exist_ok=True)
        existing = [int(p.stem.split("-")[1]) for p in self.dir.glob("part-*.parquet")]
        self.next = max(existing, default=-1) + 1

    def write(self, rows: list[dict[str, Any]]) -> None:
        if not rows:
            return
        table = pa.Table.from_pylist(rows)
        path = self.dir / f"part-{self.next:06d}.parquet"
        tmp = path.with_suffix(".parquet.tmp")
        pq.write_table(table, tmp)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
        self.next += 1


def read_parts(out_dir: Path) -> pd.DataFrame:
    """Every completed row so far (an empty frame when there is none); a task that two
    parts hold (a retried task whose first result also arrived) counts once."""
    parts = sorted((out_dir / "parts").glob("part-*.parquet"))
    if not parts:
        return pd.DataFrame()
    frame = pd.concat([pq.read_table(p).to_pandas() for p in parts], ignore_index=True)
    frame = frame.drop_duplicates(subset=["run", "variant"], keep="first")
    return frame.sort_values(["run", "variant"], kind="stable").reset_index(drop=True)


def done_tasks(out_dir: Path) -> set[tuple[int, str]]:
    frame = read_parts(out_dir)
    if frame.empty:
        return set()
    return {(int(r), str(v)) for r, v in zip(frame["run"], frame["variant"], strict=True)}


def write_table(frame: pd.DataFrame, path: Path) -> None:
    tmp = path.with_suffix(".parquet.tmp")
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), tmp)
    os.replace(tmp, path)
