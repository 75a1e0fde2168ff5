"""Exit codes of the nodes, one table for all (``attitude-run`` maps them to named
failures; a hand-started node reports them to its shell)."""

from __future__ import annotations

__all__ = [
    "EXIT_OK",
    "EXIT_FAILURE",
    "EXIT_BAD_INPUT",
    "EXIT_NO_PLANT",
    "EXIT_DISK_FULL",
    "EXIT_WRITE_FAILED",
    "EXIT_FOREIGN_PUBLISHER",
    "EXIT_FINGERPRINT_MISMATCH",
]

EXIT_OK = 0
EXIT_FAILURE = 1
"""A failure of the node's own (the simulator's graph never connected, its state
diverged)."""
EXIT_BAD_INPUT = 2
"""A refused scenario key or node parameter, named on stderr."""
EXIT_NO_PLANT = 3
"""Recorder: no state arrived within ``plant_timeout_s``."""
EXIT_DISK_FULL = 4
"""Recorder: the disk filled (ENOSPC, EDQUOT) while writing the bag; it stopped
recording and what it wrote is on disk, unfinished, for recovery."""
EXIT_WRITE_FAILED = 5
"""Recorder: writing the bag failed otherwise (an I/O error)."""
EXIT_FOREIGN_PUBLISHER = 6
"""A node of a run saw a publisher of another run, or of none, on a topic it takes
(:mod:`attitude_core.runtime.run_identity`)."""
EXIT_FINGERPRINT_MISMATCH = 7
"""A node of the run was started with another scenario than a peer."""
