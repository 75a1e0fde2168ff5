"""Where a FIS definition comes from: a mapping, a packaged file name or a YAML file
(read strictly: a duplicate key is an error, not a silently dropped term or rule)."""

from __future__ import annotations

import functools
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from attitude_core.fsw.guidance.fuzzy.files import packaged_fis_files, resolve_fis
from attitude_core.fsw.guidance.fuzzy.mamdani import MamdaniFis
from attitude_core.fsw.guidance.fuzzy.spec import FisError
from attitude_core.yamlio import load_strict

__all__ = ["load_fis"]


def load_fis(source: str | Path | Mapping[str, Any]) -> MamdaniFis:
    """Load and validate a FIS.

    ``source`` is an already-parsed dict, the bare file name of a packaged file in
    ``attitude_core/data/`` (e.g. ``"fis_attractive.yaml"``; a bare name that is not
    packaged is then tried as a path), or a path to a YAML file.
    Raises :class:`FisError` naming the file and the offending field.
    """
    if isinstance(source, Mapping):
        return MamdaniFis(source, label="<dict>")
    if not isinstance(source, (str, Path)):
        raise FisError(
            f"load_fis: source must be a path, a file name or a dict, got {type(source).__name__}"
        )
    text = str(source)
    label = text
    if text in packaged_fis_files():  # a bare name: file names contain no '/'
        path = resolve_fis(text, ".")
    else:
        path = Path(source)
        if not path.is_file():
            raise FisError(
                f"{label}: no such file (and not a packaged FIS; packaged: "
                f"{', '.join(packaged_fis_files())})"
            )
    return _from_text(path.read_text(encoding="utf-8"), label)


@functools.lru_cache(maxsize=16)
def _from_text(content: str, label: str) -> MamdaniFis:
    """The FIS of a file's text, parsed once per process for each text: a
    :class:`MamdaniFis` does not change after it is made, so every planner of a batch
    or a campaign worker shares it (an edited file is a new text, parsed anew)."""
    try:
        spec = load_strict(content)
    except yaml.YAMLError as exc:
        raise FisError(f"{label}: invalid YAML: {exc}") from None
    return MamdaniFis(spec, label=label)
