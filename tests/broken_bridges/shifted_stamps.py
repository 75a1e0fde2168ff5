"""Broken bridge: attitude and rate stamped one step late, ``(k + 1) dt`` instead of
``k dt`` (``attitude-bridge-check`` must FAIL ``stamps``)."""

import sys

from _patched_sim import run_patched

from attitude_ros import convert as cv


def one_step_later(msg, node) -> None:
    cv.set_stamp(msg.header.stamp, cv.stamp_ns(msg.header.stamp) + node.stepper.dt_ns)


if __name__ == "__main__":
    sys.exit(run_patched(attitude=one_step_later, rate=one_step_later))
