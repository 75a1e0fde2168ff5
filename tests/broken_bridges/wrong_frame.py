"""Broken bridge: the attitude published in frame ``body`` instead of ``inertial``
(``attitude-bridge-check`` must FAIL ``frames``)."""

import sys

from _patched_sim import run_patched


def body_frame(msg, node) -> None:
    msg.header.frame_id = "body"


if __name__ == "__main__":
    sys.exit(run_patched(attitude=body_frame))
