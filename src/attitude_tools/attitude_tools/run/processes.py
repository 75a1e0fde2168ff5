"""Children that die with their parent (Linux): ``prctl(PR_SET_PDEATHSIG, SIGTERM)``.

:func:`die_with_parent` gives a ``Popen(preexec_fn=...)`` that asks the kernel to send
the child SIGTERM when the process that started it exits, however it exits (SIGKILL
included). The setting survives ``exec`` (of the ``ros2 run`` shim, then of the node).
The kernel sends it when the *thread* that called ``Popen`` exits: start children from
the main thread; and a process killed with threads of its own can signal its children
before it is gone (``os.getppid()`` still names it for a moment; once per exiting
thread, so a child may get the signal twice).
Race-free: if the parent died between ``fork`` and ``prctl``, the child sees another
parent and exits at once. On other systems the hook does nothing; the nodes' parent
watchdog (``attitude_ros.runner``, :data:`~attitude_core.runtime.process_identity.OWNER_ENV`)
still stops them, within a second.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
from collections.abc import Callable

__all__ = ["die_with_parent"]

PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGTERM) -> Callable[[], None] | None:
    """A ``preexec_fn`` that makes the child get ``sig`` when this process exits; None
    off Linux."""
    if not sys.platform.startswith("linux"):
        return None
    prctl = ctypes.CDLL(None, use_errno=True).prctl  # looked up here, not after fork
    parent = os.getpid()

    def preexec() -> None:
        if prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
        if os.getppid() != parent:  # the parent died before prctl: no signal will come
            os._exit(128 + int(sig))

    return preexec
