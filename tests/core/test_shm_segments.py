"""Fast DDS segment files (``attitude_core.runtime.shm_segments``), on a directory of
the test's own: which are owned, which are orphans, what a sweep removes."""

import fcntl
import os
import subprocess
import sys
import time

from attitude_core.runtime import shm_segments as shm

SEG = "fastrtps_0123456789abcdef"


def _segment(folder, name: str, age_s: float = 60.0) -> None:
    for path in (folder / name, folder / f"{name}_el"):
        path.write_bytes(b"x")
        past = time.time() - age_s
        os.utime(path, (past, past))


def test_a_sweep_removes_orphans_only(tmp_path):
    orphan, young, held = SEG, "fastrtps_00000000000000aa", "fastrtps_00000000000000bb"
    _segment(tmp_path, orphan)
    _segment(tmp_path, young, age_s=0.0)
    _segment(tmp_path, held)
    for other in ("fastrtps_port7000", "fastrtps_port7000_el", "sem.fastrtps_port7000_mutex"):
        (tmp_path / other).write_bytes(b"x")  # ports: shared by several processes, kept
    (tmp_path / "fastrtps_0123_el").write_bytes(b"x")  # not a segment's name
    holder = subprocess.Popen(  # a live owner: holds the lock until told to stop
        [
            sys.executable,
            "-c",
            "import fcntl, os, sys; fd = os.open(sys.argv[1], os.O_RDONLY); "
            "fcntl.flock(fd, fcntl.LOCK_EX); print('held', flush=True); sys.stdin.read()",
            str(tmp_path / f"{held}_el"),
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        assert shm.sweep_orphan_segments(str(tmp_path)) == 1
        left = set(os.listdir(tmp_path))
        assert orphan not in left and f"{orphan}_el" not in left
        assert {young, f"{young}_el", held, f"{held}_el", "fastrtps_port7000"} <= left
        assert shm.sweep_orphan_segments(str(tmp_path)) == 0
    finally:
        assert holder.stdin is not None
        holder.stdin.close()
        holder.wait()
    assert shm.sweep_orphan_segments(str(tmp_path)) == 1  # its owner is gone now
    assert held not in set(os.listdir(tmp_path))


def test_a_process_finds_and_removes_the_segments_it_owns(tmp_path):
    _segment(tmp_path, SEG)
    _segment(tmp_path, "fastrtps_00000000000000cc")  # someone else's
    fd = os.open(tmp_path / f"{SEG}_el", os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        assert shm.own_segments(str(tmp_path)) == [SEG]
        assert shm.remove_own_segments(str(tmp_path)) == [SEG]
        assert sorted(os.listdir(tmp_path)) == [
            "fastrtps_00000000000000cc",
            "fastrtps_00000000000000cc_el",
        ]
    finally:
        os.close(fd)
    assert shm.own_segments(str(tmp_path)) == []


def test_a_missing_folder_sweeps_nothing(tmp_path):
    assert shm.sweep_orphan_segments(str(tmp_path / "none")) == 0
