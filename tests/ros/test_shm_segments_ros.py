"""A run leaves no Fast DDS shared-memory segment behind (``/dev/shm``): every node
process that ends removes the one it owns, also on its fast exit
(``attitude_ros.runner.exit_process``)."""

import os
import re
import threading
from pathlib import Path

import pytest
from support import attitude_run, needs_workspace

ROOT = Path(__file__).resolve().parents[2]
SHM = Path("/dev/shm")
SEGMENT = re.compile(r"^fastrtps_[0-9a-f]{16}(_el)?$")
pytestmark = [pytest.mark.ros, needs_workspace]


def _segments() -> set[str]:
    return {name for name in os.listdir(SHM) if SEGMENT.match(name)}


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm on this machine")
def test_a_run_leaves_no_segment_of_its_nodes(tmp_path, ros_domain):
    before = _segments()
    seen: set[str] = set()  # the run's own segments, seen while it runs
    done = threading.Event()

    def watch() -> None:
        while not done.wait(0.05):
            seen.update(_segments() - before)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        proc = attitude_run(ROOT / "scenarios" / "case1.yaml", tmp_path / "run", ros_domain)
    finally:
        done.set()
        watcher.join()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    # the run's nodes made segments (at least the loop's four and the manager's) ...
    assert len({name.removesuffix("_el") for name in seen}) >= 5, sorted(seen)
    # ... and none of them is left
    assert not (seen & _segments()), sorted(seen & _segments())
