"""``attitude-run``'s wait for its lifecycle manager (``ManagerLink.wait``): it keeps
telling the manager of nodes that end during the bring-down (``on_poll``) until the
manager has exited, or gives up at the deadline."""

from __future__ import annotations

import subprocess
import sys
import time

from attitude_tools.run.manager_link import POLL_S, ManagerLink


def _process(seconds: float) -> subprocess.Popen[bytes]:
    code = f"import time; time.sleep({seconds})"
    return subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE
    )


def test_wait_polls_until_the_manager_exits():
    link = ManagerLink(_process(0.5), {})
    polls: list[float] = []
    assert link.wait(30.0, lambda: polls.append(time.monotonic()))
    assert link.proc.returncode == 0
    assert len(polls) >= 2  # called again while it waited, not only once
    gaps = [b - a for a, b in zip(polls, polls[1:], strict=False)]
    assert min(gaps) >= 0.5 * POLL_S  # a poll every POLL_S, not a busy loop


def test_wait_gives_up_at_the_deadline():
    proc = _process(30.0)
    try:
        link = ManagerLink(proc, {})
        polls: list[int] = []
        started = time.monotonic()
        assert not link.wait(0.3, lambda: polls.append(1))
        assert time.monotonic() - started >= 0.3 and proc.poll() is None and polls
    finally:
        proc.kill()
        proc.wait()
