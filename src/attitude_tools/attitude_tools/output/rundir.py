"""Output directories written whole: staged in a temporary sibling, then moved into place.

Used by ``attitude-offline``, ``attitude-run`` and ``attitude-report``: a reader never
sees a half-written directory, and an existing one is replaced only when it holds
previous output of the same kind.

A staging directory is named ``<prefix><out name>-XXXXXXXX`` beside ``--out`` and holds
an owner file (:data:`OWNER_FILE`: the owner's PID, start time and boot ID, the
``--out`` path, the UTC start), so that a later run into the same ``--out`` can tell a
stale staging directory (its owner is gone) from a live one (never touched); see
:func:`stale_stages`. Writing that file, fsynced, is the probe that the output
directory is writable; :func:`stage` also requires ``min_free_bytes`` free there. A
failure is an :class:`OutputDirError` naming ``--out``, the directory and the cause
(``Read-only file system``, ``No space left on device``, ``Permission denied``), and
nothing is left behind.
"""

from __future__ import annotations

import glob
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from attitude_core.runtime.process_identity import ProcessIdentity

__all__ = [
    "OutputDirError",
    "OWNER_FILE",
    "MIN_FREE_BYTES",
    "check_replaceable",
    "stage",
    "stale_stages",
    "publish",
]

OWNER_FILE = ".owner.json"
MIN_FREE_BYTES = 16 * 2**20
"""Default free space required beside ``--out`` before anything is written."""


class OutputDirError(OSError):
    """The output directory cannot be written; the message names the path and the cause."""


def check_replaceable(out_dir: str | os.PathLike[str], markers: tuple[str, ...], what: str) -> Path:
    """``out_dir`` as an absolute path; FileExistsError when it exists and is neither empty
    nor previous output (a directory holding one of ``markers``)."""
    out = Path(out_dir).resolve()
    if out.exists() and (
        not out.is_dir() or (any(out.iterdir()) and not any((out / m).exists() for m in markers))
    ):
        raise FileExistsError(f"--out {out}: exists and is not a previous {what}")
    return out


def _cannot_write(out_dir: Path, where: Path, err: OSError) -> OutputDirError:
    return OutputDirError(f"--out {out_dir}: cannot write in {where}: {err.strerror or err}")


def _make_parents(out_dir: Path) -> Path | None:
    """Create ``out_dir``'s parent; the topmost directory created (None: all existed)."""
    missing = [p for p in [out_dir.parent, *out_dir.parent.parents] if not p.exists()]
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        top = missing[-1] if missing else None
        if top is not None:
            shutil.rmtree(top, ignore_errors=True)
        raise _cannot_write(out_dir, Path(err.filename or out_dir.parent).parent, err) from None
    return missing[-1] if missing else None


def _write_owner(tmp: Path, out_dir: Path) -> None:
    """The owner file, written and fsynced (a failure here is the probe's answer)."""
    record = {
        "owner": ProcessIdentity.current().encode(),
        "out": str(out_dir),
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    part = tmp / (OWNER_FILE + ".part")
    with open(part, "w") as f:
        json.dump(record, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(part, tmp / OWNER_FILE)
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def stage(out_dir: Path, prefix: str, min_free_bytes: int = MIN_FREE_BYTES) -> Path:
    """A new staging directory beside ``out_dir`` (``prefix`` + its name + random), with
    its owner file; :class:`OutputDirError` when it cannot be written or less than
    ``min_free_bytes`` are free (nothing is left behind)."""
    created = _make_parents(out_dir)
    tmp = None
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f"{prefix}{out_dir.name}-", dir=out_dir.parent))
        _write_owner(tmp, out_dir)
        st = os.statvfs(tmp)
        free = st.f_bavail * st.f_frsize
        if free < min_free_bytes:
            raise OutputDirError(
                f"--out {out_dir}: not enough free space in {out_dir.parent}: "
                f"{free / 2**20:.1f} MiB free, at least {min_free_bytes / 2**20:.0f} MiB needed"
            )
    except OSError as err:  # OutputDirError included
        for path in (tmp, created):
            if path is not None:
                shutil.rmtree(path, ignore_errors=True)
        if isinstance(err, OutputDirError):
            raise
        raise _cannot_write(out_dir, out_dir.parent, err) from None
    return tmp


def stale_stages(out_dir: Path, prefix: str) -> list[Path]:
    """Staging directories of ``out_dir`` whose owner has died (its owner file names
    ``out_dir`` and a process that no longer runs), oldest first. A directory without a
    readable owner file (being created, or not ours) is left alone."""
    found = []
    for path in out_dir.parent.glob(f"{glob.escape(prefix + out_dir.name)}-*"):
        try:
            record = json.loads((path / OWNER_FILE).read_text())
            owner = ProcessIdentity.decode(record["owner"])
            mine = record["out"] == str(out_dir)
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if mine and not owner.alive():
            found.append(path)
    return sorted(found, key=lambda p: p.stat().st_mtime)


def publish(tmp: Path, out_dir: Path) -> None:
    """Move ``tmp`` to ``out_dir``, replacing a previous one; if the move fails, the
    previous directory is put back."""
    old = None
    try:
        if out_dir.exists():
            old = Path(tempfile.mkdtemp(prefix=".old-", dir=out_dir.parent))
            os.replace(out_dir, old / "previous")
        os.replace(tmp, out_dir)
    except BaseException:
        if old is not None and not out_dir.exists():
            os.replace(old / "previous", out_dir)
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    (out_dir / OWNER_FILE).unlink(missing_ok=True)  # a published directory has no owner
