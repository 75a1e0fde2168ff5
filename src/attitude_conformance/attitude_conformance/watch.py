"""When the check gives up before the script's end (plain data, no ROS): a bridge endpoint
with an incompatible QoS and still no state, the launched bridge's exit, the time limit."""

from __future__ import annotations

from .bridge_process import BridgeProcess
from .driver import Driver

INCOMPATIBLE_WAIT_S = 3.0  # give up this long after an incompatible-QoS event without state


class Watch:
    """Stops the driver's script, with the reason, when the check cannot go on."""

    def __init__(self, driver: Driver, timeout_s: float, started: float) -> None:
        self.driver, self.timeout_s, self.started = driver, timeout_s, started
        self.incompatible_since: float | None = None

    def check(
        self, now: float, incompatible: bool, have_state: bool, bridge: BridgeProcess | None
    ) -> None:
        """Called often: ``incompatible`` once an incompatible-QoS event came, ``have_state``
        once an attitude came, ``bridge`` the launched bridge (None: none launched)."""
        if incompatible and not have_state:
            self.incompatible_since = self.incompatible_since or now
            if now - self.incompatible_since > INCOMPATIBLE_WAIT_S:
                self.driver.abort("no state: a bridge endpoint has an incompatible QoS", now)
        if bridge is not None and bridge.exited() is not None:
            self.driver.abort(f"the bridge exited with code {bridge.exited()}", now)
        elif now - self.started > self.timeout_s:
            self.driver.abort(f"timeout after {self.timeout_s:g} s", now)
