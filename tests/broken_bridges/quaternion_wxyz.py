"""Broken bridge: the attitude quaternion published in (w, x, y, z) order in the
(x, y, z, w) fields (``attitude-bridge-check`` must FAIL ``quaternion``)."""

import sys

from _patched_sim import run_patched


def scalar_first(msg, node) -> None:
    q = msg.quaternion
    q.x, q.y, q.z, q.w = q.w, q.x, q.y, q.z


if __name__ == "__main__":
    sys.exit(run_patched(attitude=scalar_first))
