"""How fast a run notices a foreign publisher, through the real node graph.

Run: .venv/bin/python bench/foreign_detection_bench.py [--repeats N]

Each repeat starts `attitude-run scenarios/case1.yaml --mode realtime` on a reserved ROS
domain, waits for its first states, then creates a publisher of /spacecraft/attitude in
this process (a node in no run) and notes the wall time. It prints, per repeat and as
median and max: the delay from the publisher's creation to the first "foreign
publisher" line of any node's log (ROS log stamps are wall time), and to attitude-run's
exit. Not a test: nothing timed is asserted.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STAMP = re.compile(r"^\[\w+\] \[(\d+\.\d+)\] .*foreign publisher /stray_probe")


def one(domain_env: dict[str, str]) -> tuple[float, float]:
    import rclpy
    from geometry_msgs.msg import QuaternionStamped
    from rclpy.executors import SingleThreadedExecutor

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        run = subprocess.Popen(
            [sys.executable.replace("python", "attitude-run"), str(ROOT / "scenarios/case1.yaml"),
             "--out", str(out), "--quiet", "--mode", "realtime"],
            env=domain_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        ctx = rclpy.Context()
        rclpy.init(context=ctx, domain_id=int(domain_env["ROS_DOMAIN_ID"]))
        node = rclpy.create_node("stray_probe", context=ctx)
        seen: list[int] = []
        node.create_subscription(QuaternionStamped, "/spacecraft/attitude", seen.append, 10)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        try:
            while len(seen) < 20:
                executor.spin_once(timeout_sec=0.05)
            created = time.time()
            node.create_publisher(QuaternionStamped, "/spacecraft/attitude", 10)
            while run.poll() is None:
                executor.spin_once(timeout_sec=0.05)
            ended = time.time()
        finally:
            if run.poll() is None:
                run.kill()
            executor.shutdown()
            node.destroy_node()
            ctx.try_shutdown()
        stamps = [
            float(m.group(1))
            for log in (out / "logs").glob("*.log")
            for line in log.read_text().splitlines()
            if (m := STAMP.match(line))
        ]
        return min(stamps) - created, ended - created


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    from attitude_tools.run.domain import reserve_domain

    detect, stop = [], []
    for k in range(args.repeats):
        with reserve_domain() as domain:
            d, s = one(domain.env())
        detect.append(d)
        stop.append(s)
        print(f"repeat {k}: detected after {d:.3f} s, attitude-run ended after {s:.3f} s")
    print(
        f"detection: median {statistics.median(detect):.3f} s, max {max(detect):.3f} s; "
        f"run ended: median {statistics.median(stop):.3f} s, max {max(stop):.3f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
