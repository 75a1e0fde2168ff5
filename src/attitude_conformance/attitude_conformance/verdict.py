"""The check's last act (no ROS): judge every point, stop a launched bridge, print one line
per point and the summary (the bridge's last output lines on stderr when a point failed);
the exit code, 0 when no point failed, else 1."""

from __future__ import annotations

import os
import sys

from .bridge_process import BridgeProcess
from .checker import judge
from .checks_process import TopicQos, check_plant, check_qos, check_sigint
from .record import FAIL, Recording, Result, summary

NO_STATE_HINT = (
    "; no state received: is the bridge running on this ROS_DOMAIN_ID, started with "
    "lockstep.expected_subscribers:=1?"
)


def _sigint(bridge: BridgeProcess | None) -> Result:
    """SIGINT to a launched bridge still running, and the verdict on its exit."""
    before, code, took, output = None, None, 0.0, ""
    if bridge is not None:
        before = bridge.exited()
        if before is None:
            code, took = bridge.interrupt()
        output = bridge.output()
    return check_sigint(bridge is not None, before, code, took, output)


def report(
    rec: Recording,
    topics: list[TopicQos],
    incompatible: bool,
    bridge: BridgeProcess | None,
    what: str,
) -> int:
    """Judge, stop a launched bridge, print; the exit code. ``topics``: the connection as
    the node saw it, ``incompatible``: an incompatible-QoS event came, ``what``: the mode
    and scenario, for the summary."""
    exited = bridge is not None and bridge.exited() is not None
    if not rec.attitude and rec.aborted and not incompatible and not exited:
        rec.aborted += NO_STATE_HINT
    results = [check_qos(topics, os.environ.get("ROS_DOMAIN_ID", "0")), check_plant(topics)]
    results += judge(rec)
    results.append(_sigint(bridge))
    for r in results:
        print(r.line(), flush=True)
    print(summary(results, what), flush=True)
    failed = any(r.status == FAIL for r in results)
    if failed and bridge is not None:
        print(f"bridge output (last lines):\n{bridge.tail()}", file=sys.stderr, flush=True)
    return 1 if failed else 0
