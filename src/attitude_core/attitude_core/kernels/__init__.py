"""Which form of the per-step kernels runs: the compiled one, or the Python reference.

The compiled kernels (:mod:`attitude_core.kernels._kernels`, C built ahead of time by the
package install; one ``.pxi`` per Python module it mirrors) are used when they are
built. ``ATTITUDE_KERNELS=python`` selects the Python reference instead (to debug, or to
compare); a missing build falls back to it too, with the same results to the bit
(``tests/core/test_kernels.py``) at Python's speed. :data:`ACTIVE` says which one this
process uses; :func:`selected` switches for a block (the tests run each test class with
either, as CPython's ``heapq`` tests run with ``_heapq`` and without).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType

__all__ = ["ENV", "ACTIVE", "CHOICES", "built", "compiled", "selected"]

ENV = "ATTITUDE_KERNELS"
"""Environment variable: ``compiled`` (the default) or ``python``."""

CHOICES = ("compiled", "python")


def built() -> ModuleType | None:
    """The compiled kernels module when it is built (whatever :data:`ENV` says), else
    None (a source tree without the install step)."""
    try:
        from attitude_core.kernels import _kernels
    except ImportError:
        return None
    return _kernels


def _load() -> ModuleType | None:
    choice = os.environ.get(ENV, "compiled").strip().lower()
    if choice not in CHOICES:
        raise ValueError(f"{ENV}={choice!r}: expected 'compiled' or 'python'")
    return None if choice == "python" else built()


compiled: ModuleType | None = _load()
"""The compiled kernels module, or None when the Python reference runs."""

ACTIVE = "python" if compiled is None else "compiled"


@contextmanager
def selected(choice: str) -> Iterator[ModuleType | None]:
    """Within the block, :data:`compiled` (and :data:`ACTIVE`) are ``choice``'s: the
    compiled kernels (``"compiled"``: they must be built) or None (``"python"``: the
    Python references); the process's own are restored on leaving it.

    What is made inside keeps the choice for its life: a ``ConeGeometry`` its kernel, an
    ``FepfPlanner`` its core and state, a ``Guidance`` its core and state, a
    ``RigidBody`` its step, :func:`attitude_core.loop.loop_plant.loop_plant`'s plant;
    ``commanded_torque`` follows it per call. The MRP helpers of
    :mod:`attitude_core.models.mrp` are bound when it is imported (equal to the bit
    either way). For the tests and comparisons in one process; not thread-safe.
    """
    global compiled, ACTIVE
    if choice not in CHOICES:
        raise ValueError(f"kernels.selected({choice!r}): expected 'compiled' or 'python'")
    module = None if choice == "python" else built()
    if choice == "compiled" and module is None:
        raise RuntimeError("the compiled kernels are not built (run tools/bootstrap)")
    saved = compiled, ACTIVE
    compiled, ACTIVE = module, choice
    try:
        yield module
    finally:
        compiled, ACTIVE = saved
