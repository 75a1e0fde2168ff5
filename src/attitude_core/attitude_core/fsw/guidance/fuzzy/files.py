"""FIS data files for the FEPF magnitudes: the packaged ones and a scenario's own.

A scenario names each FIS (attractive, repulsive) either by the bare file name of one
shipped in ``attitude_core/data/`` or by a path containing ``/``, relative to the
scenario's directory.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["packaged_fis_files", "resolve_fis"]


def packaged_fis_files() -> list[str]:
    """Names of the FIS YAML files shipped in ``attitude_core/data/``."""
    data = resources.files("attitude_core") / "data"
    return sorted(p.name for p in data.iterdir() if p.name.endswith(".yaml"))


def resolve_fis(name: str, base_dir: str | os.PathLike[str]) -> Path:
    """Absolute path of the FIS file ``name``.

    A name without ``/`` must be a packaged file (:func:`packaged_fis_files`); a name
    with ``/`` is a path relative to ``base_dir`` (an absolute one stays as it is) and
    must be an existing file. Raises :class:`ValueError` otherwise.
    """
    if "/" not in name:
        packaged = packaged_fis_files()
        if name not in packaged:
            raise ValueError(
                f"{name!r} is not a packaged FIS file {packaged}; give your own file as a "
                "path containing '/' (relative to the scenario)"
            )
        return Path(str(resources.files("attitude_core") / "data" / name)).resolve()
    path = Path(base_dir) / name
    if not path.is_file():
        raise ValueError(f"file {str(path)!r} does not exist")
    return path.resolve()


def fis_value(name: str, base_dir: str | os.PathLike[str]) -> str:
    """A scenario's FIS value: a packaged name as given, a path made absolute
    (:func:`resolve_fis` checks both and raises :class:`ValueError`)."""
    path = resolve_fis(name, base_dir)
    return name if "/" not in name else str(path)
