"""A disk cache of the FIS lookup tables, so a process does not rebuild them.

Building a refined 2-input table takes a few tenths of a second (the planner's whole
configure time, most of a cold offline run's). The table is a pure function of the FIS
definition and of the code that builds it, so it is stored once per machine under
:func:`cache_dir` and read back by every later process, bit for bit.

* Key: SHA-256 of the FIS definition (canonical JSON), the source of the modules that
  build a table (:data:`BUILDER_MODULES`) and the NumPy version. An edited FIS file or
  an edited builder gets a new entry; nothing is ever stale.
* Entry: ``<key>.npz`` with the knots, the values, the error estimate and the
  tolerance (no pickle),
  written to a temporary file and renamed, so a reader never sees half an entry and two
  processes writing the same entry both leave a whole one.
* A missing, unreadable or malformed entry is rebuilt; a cache that cannot be written
  (read-only home, full disk) is skipped. The cache never fails a run.

Location: ``ATTITUDE_FIS_CACHE_DIR`` if set (empty or ``off``: no disk cache), else
``$XDG_CACHE_HOME/attitude_stack/fis_tables`` (default ``~/.cache``).
"""

from __future__ import annotations

import functools
import hashlib
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["ENV", "BUILDER_MODULES", "cache_dir", "cache_key", "load", "store"]

ENV = "ATTITUDE_FIS_CACHE_DIR"
BUILDER_MODULES = ("mamdani.py", "membership.py", "refine.py", "spec.py", "table.py")
"""The files of this package whose code decides a table's contents (the cache key)."""

_Floats = npt.NDArray[np.float64]
Entry = tuple[tuple[_Floats, ...], _Floats, float, float | None]
"""(axes, values, max_abs_error_estimate, tol) of one table."""


def cache_dir() -> Path | None:
    """Where tables are cached; None when the disk cache is off."""
    chosen = os.environ.get(ENV)
    if chosen is not None:
        return None if chosen.strip() in ("", "off") else Path(chosen)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "attitude_stack" / "fis_tables"


@functools.cache
def _builder_digest() -> bytes:
    here = Path(__file__).resolve().parent
    h = hashlib.sha256(np.__version__.encode())
    for name in BUILDER_MODULES:
        h.update(name.encode() + b"\0" + (here / name).read_bytes())
    return h.digest()


def cache_key(spec_json: str, build_args: str) -> str:
    """The entry name of a table: definition, build arguments, builder code, NumPy."""
    h = hashlib.sha256(_builder_digest())
    h.update(spec_json.encode() + b"\0" + build_args.encode())
    return h.hexdigest()


def load(key: str, ndim: int) -> Entry | None:
    """The cached table ``key`` with ``ndim`` axes, or None (absent or unusable)."""
    where = cache_dir()
    if where is None:
        return None
    try:
        with np.load(where / f"{key}.npz", allow_pickle=False) as data:
            axes = tuple(np.array(data[f"axis{i}"], dtype=np.float64) for i in range(ndim))
            values = np.array(data["values"], dtype=np.float64)
            err = float(data["error"])
            tol_value = float(data["tol"])
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):  # absent, damaged
        return None
    shape = tuple(len(a) for a in axes)
    if values.shape != shape or any(a.ndim != 1 or len(a) < 2 for a in axes):
        return None
    if not (np.all(np.isfinite(values)) and all(np.all(np.diff(a) > 0.0) for a in axes)):
        return None
    return axes, values, err, (None if np.isnan(tol_value) else tol_value)


def store(key: str, entry: Entry) -> None:
    """Write ``entry`` as ``key`` (atomic rename); skipped when the cache is not writable."""
    where = cache_dir()
    if where is None:
        return
    axes, values, err, tol = entry
    arrays: dict[str, Any] = {f"axis{i}": a for i, a in enumerate(axes)}
    arrays.update(
        values=values, error=np.float64(err), tol=np.float64(np.nan if tol is None else tol)
    )
    try:
        where.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key}.", suffix=".npz", dir=where)
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, **arrays)
            os.replace(tmp, where / f"{key}.npz")
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:  # read-only or full: the next process builds the table again
        return
