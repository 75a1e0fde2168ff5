"""Which form of the per-step kernels runs: the compiled one, or the Python reference.

The compiled kernels (:mod:`attitude_core.gnc._kernels`, C built ahead of time by the
package install) are used when they are built. ``ATTITUDE_KERNELS=python`` selects the
Python reference instead (to debug, or to compare); a missing build falls back to it
too, with the same results (``tests/core/test_kernels.py``) at Python's speed.
:data:`ACTIVE` says which one this process uses.
"""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["ENV", "ACTIVE", "compiled"]

ENV = "ATTITUDE_KERNELS"
"""Environment variable: ``compiled`` (the default) or ``python``."""


def _load() -> ModuleType | None:
    choice = os.environ.get(ENV, "compiled").strip().lower()
    if choice not in ("compiled", "python"):
        raise ValueError(f"{ENV}={choice!r}: expected 'compiled' or 'python'")
    if choice == "python":
        return None
    try:
        from attitude_core.gnc import _kernels
    except ImportError:  # not built (a source tree without the install step)
        return None
    return _kernels


compiled: ModuleType | None = _load()
"""The compiled kernels module, or None when the Python reference runs."""

ACTIVE = "python" if compiled is None else "compiled"
