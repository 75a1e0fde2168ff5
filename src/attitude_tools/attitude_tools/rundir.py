"""Output directories written whole: staged in a temporary sibling, then moved into place.

Used by ``attitude-offline``, ``attitude-run`` and ``attitude-report``: a reader never
sees a half-written directory, and an existing one is replaced only when it holds
previous output of the same kind.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

__all__ = ["check_replaceable", "stage", "publish"]


def check_replaceable(out_dir, markers: tuple[str, ...], what: str) -> Path:
    """``out_dir`` as an absolute path; FileExistsError when it exists and is neither empty
    nor previous output (a directory holding one of ``markers``)."""
    out = Path(out_dir).resolve()
    if out.exists() and (
        not out.is_dir() or (any(out.iterdir()) and not any((out / m).exists() for m in markers))
    ):
        raise FileExistsError(f"--out {out}: exists and is not a previous {what}")
    return out


def stage(out_dir: Path, prefix: str) -> Path:
    """A new temporary directory beside ``out_dir`` (``prefix`` + random)."""
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=prefix, dir=out_dir.parent))


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
