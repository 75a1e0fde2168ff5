"""Strict JSON for every summary we write: no ``NaN`` or ``Infinity``, ever.

A non-finite float becomes ``null``, and the document gets a ``non_finite`` mapping
from each such field (dotted path, list indices as numbers) to the value it had
(``"NaN"``, ``"Infinity"``, ``"-Infinity"``). The dump uses ``allow_nan=False``, so a
non-finite value that slipped past would raise instead of writing invalid JSON.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["NON_FINITE_KEY", "finite_only", "dumps_strict", "dump_strict"]

NON_FINITE_KEY = "non_finite"
_TEXT = {math.inf: "Infinity", -math.inf: "-Infinity"}


def finite_only(
    value: Any, path: str = "", found: dict[str, str] | None = None
) -> tuple[Any, dict[str, str]]:
    """``value`` with every non-finite float replaced by None; returns (clean, found),
    ``found`` mapping each replaced field's path to its original value as JSON spells it."""
    found = {} if found is None else found
    if isinstance(value, Mapping):
        return {
            k: finite_only(v, f"{path}.{k}" if path else str(k), found)[0] for k, v in value.items()
        }, found
    if isinstance(value, (list, tuple)):
        return [finite_only(v, f"{path}.{i}", found)[0] for i, v in enumerate(value)], found
    if hasattr(value, "item") and callable(value.item) and getattr(value, "ndim", 1) == 0:
        value = value.item()  # numpy scalar
    if isinstance(value, float) and not math.isfinite(value):
        found[path] = _TEXT.get(value, "NaN")
        return None, found
    return value, found


def dumps_strict(document: Mapping[str, Any], **kwargs: Any) -> str:
    """``json.dumps`` of ``document`` made finite (see module docstring)."""
    clean, found = finite_only(document)
    if found:
        clean[NON_FINITE_KEY] = found
    return json.dumps(clean, allow_nan=False, **kwargs)


def dump_strict(document: Mapping[str, Any], f: Any, **kwargs: Any) -> None:
    """:func:`dumps_strict` to the open text file ``f``, with a final newline."""
    f.write(dumps_strict(document, **kwargs) + "\n")
