"""Broken bridge: the example bridge as a wheel plant that ignores the command of its
second wheel (it applies, and reports, no torque on it), so ``attitude-bridge-check``
must FAIL ``wheels`` (run with a scenario that declares ``wheels.*``)."""

import sys

import numpy as np

from spacecraft_bridge_example import bridge_node


class IgnoresOneWheel(bridge_node.BridgeNode):
    def take(self, u: np.ndarray, stamp: int) -> None:
        if self.names:
            u = u.copy()
            u[1] = 0.0
        super().take(u, stamp)


if __name__ == "__main__":
    bridge_node.BridgeNode = IgnoresOneWheel  # type: ignore[misc]
    sys.exit(bridge_node.main())
