"""Broken bridge: the example bridge as a wheel plant whose wheel states carry the stamp
of the next state, ``(k + 1) dt`` instead of ``k dt`` (``attitude-bridge-check`` must FAIL
``wheels``; run with a scenario that declares ``wheels.*``)."""

import sys

from spacecraft_bridge_example import bridge_node


class StampsWheelsLate(bridge_node.BridgeNode):
    def send(self) -> None:
        bridge_node.set_stamp(self.wheel_states.header.stamp, self.stamp_ns + self.dt_ns)
        super().send()


if __name__ == "__main__":
    bridge_node.BridgeNode = StampsWheelsLate  # type: ignore[misc]
    sys.exit(bridge_node.main())
