"""Fast DDS's shared-memory segments: the one a node process owns, and those whose owner
is gone.

Every Fast DDS participant (one per node process here) creates a segment in
``/dev/shm``: ``fastrtps_<16 hex>`` with a lock file ``fastrtps_<16 hex>_el`` that the
owner holds with ``flock`` while it lives. A participant destroyed in order removes
both; a process that ends without destroying it (``os._exit`` after a context whose
destruction was deferred, SIGKILL, a crash) leaves them, about 0.5 MB each, and
nothing removes them later (Fast DDS's ``fastdds shm clean`` does, by hand).

* :func:`remove_own_segments`: a node's fast exit removes the segment it still owns;
* :func:`sweep_orphan_segments`: ``attitude-run`` removes, before it starts the nodes,
  the segments no process holds (the lock file free) that are older than
  :data:`MIN_AGE_S` (a participant being created has its lock file a moment before
  it takes the lock).

No rclpy here: files and locks only.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import time

__all__ = ["SHM_DIR", "MIN_AGE_S", "own_segments", "remove_own_segments", "sweep_orphan_segments"]

SHM_DIR = "/dev/shm"
MIN_AGE_S = 10.0
"""A segment whose lock file is younger than this is never swept (s)."""
_SEGMENT = re.compile(r"^fastrtps_[0-9a-f]{16}$")


def own_segments(shm_dir: str = SHM_DIR) -> list[str]:
    """Names of the segments this process owns: their lock files are open here."""
    names = []
    with contextlib.suppress(OSError):
        for fd in os.listdir("/proc/self/fd"):
            with contextlib.suppress(OSError):
                target = os.readlink(f"/proc/self/fd/{fd}")
                folder, base = os.path.split(target)
                if folder == shm_dir and base.endswith("_el") and _SEGMENT.match(base[:-3]):
                    names.append(base[:-3])
    return sorted(set(names))


def _remove(name: str, shm_dir: str) -> None:
    for path in (os.path.join(shm_dir, name), os.path.join(shm_dir, f"{name}_el")):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)


def remove_own_segments(shm_dir: str = SHM_DIR) -> list[str]:
    """Remove the segments this process still owns (at its exit, once ROS 2 is shut
    down: its peers have the segment mapped already); the names removed."""
    names = own_segments(shm_dir)
    for name in names:
        _remove(name, shm_dir)
    return names


def _held(lock_path: str) -> bool:
    """Whether a live process holds ``lock_path`` (a non-blocking ``flock`` fails)."""
    fd = os.open(lock_path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # releases the lock if we took it
    return False


def sweep_orphan_segments(shm_dir: str = SHM_DIR, min_age_s: float = MIN_AGE_S) -> int:
    """Remove the segments of processes that are gone (see the module docstring);
    returns how many. Unreadable entries are left as they are."""
    try:
        entries = os.listdir(shm_dir)
    except OSError:
        return 0
    now = time.time()
    removed = 0
    for entry in entries:
        if not (entry.endswith("_el") and _SEGMENT.match(entry[:-3])):
            continue
        lock = os.path.join(shm_dir, entry)
        with contextlib.suppress(OSError):
            if now - os.stat(lock).st_mtime < min_age_s or _held(lock):
                continue
            _remove(entry[:-3], shm_dir)
            removed += 1
    return removed
