"""``attitude-run SCENARIO.yaml --out DIR``: one scenario through the ROS 2 node graph.

Starts the recorder, the planner, the controller and the simulator as separate
processes with ``ros2 run <package> <executable> --ros-args ...`` (the real ROS 2 CLI
where one is installed, else the project's ``ros2 run`` shim), waits until the
planner reports a status that ends the slew (``PlannerStatus.ending()``; the recorder
then records ``--settle-s`` more run time, default 10 s, and closes the bag), or the
scenario time ends, or a process fails; stops every process (SIGINT, then wait,
SIGKILL after a grace period), rebuilds the run from the bag alone and writes
``DIR/summary.json`` (the offline runner's fields plus the ROS run's own),
``DIR/bag/`` and ``DIR/logs/``. Exit code: 0 reached without violation, 1 otherwise
or on a failure, 2 bad input.

The run is written to a temporary sibling of ``DIR`` that replaces ``DIR`` at the end,
also after a failure (what was recorded is kept); a bad scenario, a bad ``--param`` or
an unwritable ``DIR`` writes nothing (exit 2). The nodes die with attitude-run, even on
SIGKILL (:mod:`.child_process`); a staging directory left by a killed run is recovered
or cleaned by the next run into ``DIR`` (:mod:`.stale_run`).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from attitude_core import node_graph as graph
from attitude_core import run_identity
from attitude_core.node_graph import NodeSpec
from attitude_core.parameters import ParameterError
from attitude_core.process_identity import OWNER_ENV, ProcessIdentity
from attitude_core.recording import EXIT_NO_PLANT
from attitude_core.scenario import load_scenario
from attitude_core.status import PlannerStatus
from attitude_core.topics import ATTITUDE

from .bag_recovery import NotABagError, describe, recover_bag, run_failure, run_fields
from .bag_run import run_from_bag, summarize_bag
from .child_process import die_with_parent
from .domain import DomainBusyError, NoFreeDomain, claim_domain
from .guard_report import foreign_publishers_logged, guard_failure
from .node_params import check_node_params
from .rundir import OutputDirError, check_replaceable, publish, stage
from .stale_run import salvage_stale_runs
from .strict_json import dump_strict, dumps_strict

ROLES = tuple(n.role for n in graph.NODES)
PLANT_SIM, PLANT_EXTERNAL = "sim", "external"
PLANTS = (PLANT_SIM, PLANT_EXTERNAL)
# Shutdown budget, 5 s in all: the nodes first, then the recorder (which drains its
# queues for up to 1.5 s and finishes the bag).
NODE_GRACE_S, RECORDER_GRACE_S = 1.5, 3.0
STAGE_PREFIX = ".tmp-run-"
RUN_MIN_FREE_BYTES = 64 * 2**20  # free beside --out before a run starts (bags are MBs)


class RunError(RuntimeError):
    pass


class NodeInputError(RunError):
    """A node exited with code 2 (bad input it detected); attitude-run exits 2 too."""


NODE_EXIT_BAD_INPUT = 2  # attitude_ros.runner.EXIT_BAD_INPUT


def default_workspace() -> Path:
    """``ros2_ws/install`` of the checkout this package is installed from (editable)."""
    return Path(__file__).resolve().parents[3] / "ros2_ws" / "install"


def ros_environment(workspace: str | None = None) -> dict[str, str]:
    """Environment for the nodes: the caller's, plus the colcon workspace when our packages
    are not on ``AMENT_PREFIX_PATH`` yet (sourced once, as ``install/setup.bash`` does).

    The virtualenv's prefix is on ``AMENT_PREFIX_PATH`` (rclpy and the message packages of
    the PyPI wheels live there); discovery defaults to this host
    (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) unless the caller set it.
    """
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env["PYTHONUNBUFFERED"] = "1"
    venv_bin = str(Path(sys.prefix) / "bin")
    if venv_bin not in env.get("PATH", "").split(os.pathsep):
        env["PATH"] = env.get("PATH", "") + os.pathsep + venv_bin
    prefixes = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if (
        any(
            (Path(p) / "share/ament_index/resource_index/packages/attitude_planner").exists()
            for p in prefixes
        )
        and workspace is None
    ):
        return env
    ws = Path(workspace) if workspace else default_workspace()
    setup = ws / "setup.bash"
    if not setup.is_file():
        raise RunError(
            f"colcon workspace not built: {setup} does not exist "
            "(run `bash tools/bootstrap`, or pass --workspace)"
        )
    if sys.prefix not in prefixes:
        prefixes.append(sys.prefix)
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(prefixes)
    out = subprocess.run(
        ["bash", "-c", 'set +u; source "$1" >/dev/null && env -0', "_", str(setup)],
        env=env,
        capture_output=True,
        check=False,
    )
    if out.returncode != 0:
        raise RunError(f"sourcing {setup} failed: {out.stderr.decode(errors='replace')}")
    sourced = dict(item.split("=", 1) for item in out.stdout.decode().split("\0") if "=" in item)
    for key in ("AMENT_PREFIX_PATH", "PYTHONPATH", "PATH", "COLCON_PREFIX_PATH", "LD_LIBRARY_PATH"):
        if key in sourced:
            env[key] = sourced[key]
    return env


class NodeGraph:
    """The four node processes of one run, with their logs."""

    def __init__(self, ros2: str, env: dict[str, str], log_dir: Path, cwd: Path) -> None:
        self.ros2, self.env, self.log_dir, self.cwd = ros2, env, log_dir, cwd
        self.procs: dict[str, subprocess.Popen] = {}

    def start(self, spec: NodeSpec, ros_args: list[str], name: str | None = None) -> None:
        """Start ``spec``'s executable; its log and key are ``name`` (default: its role)."""
        name = spec.role if name is None else name
        env = {**self.env, OWNER_ENV: ProcessIdentity.current().encode()}  # parent watchdog
        with open(self.log_dir / f"{name}.log", "wb") as log:  # the child keeps its copy
            self.procs[name] = subprocess.Popen(
                [self.ros2, "run", spec.package, spec.executable, "--ros-args", *ros_args],
                env=env,
                cwd=self.cwd,
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
                preexec_fn=die_with_parent(),  # SIGTERM when we die, even by SIGKILL
            )  # we, not the terminal, decide the shutdown order

    def exited(self) -> dict[str, int]:
        return {n: p.returncode for n, p in self.procs.items() if p.poll() is not None}

    def stop(self, names, grace_s: float) -> dict[str, int]:
        """SIGINT to each, wait up to ``grace_s`` together, then SIGKILL the rest."""
        live = [self.procs[n] for n in names if self.procs[n].poll() is None]
        for p in live:
            p.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace_s
        for p in live:
            try:
                p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        return {n: self.procs[n].returncode for n in names}

    def error_line(self, name: str) -> str:
        """The last line of ``name``'s log that reports an error (else its last line)."""
        text = (self.log_dir / f"{name}.log").read_text(errors="replace").splitlines()
        errors = [line for line in text if "error" in line.lower()]
        return (errors or text or ["(empty log)"])[-1].strip()

    def tail(self, name: str, lines: int = 15) -> str:
        text = (self.log_dir / f"{name}.log").read_text(errors="replace").splitlines()
        return "\n".join(f"    {line}" for line in text[-lines:])


def run_scenario(
    scenario_path: str,
    out_dir: str,
    time_mode: str = "lockstep",
    timeout_s: float | None = None,
    workspace: str | None = None,
    settle_s: float = 10.0,
    log=print,
    node_params: dict[str, list[str]] | None = None,
    plant: str = PLANT_SIM,
    plant_timeout_s: float = 60.0,
    namespace: str | None = None,
) -> tuple[dict, Path]:
    """Run one scenario through the node graph; return (summary, run directory).

    Every node is started in the run's namespace (``namespace``, default a fresh
    ``/attitude_run_<id>``; :mod:`attitude_core.run_identity`). Without ``ROS_DOMAIN_ID``
    in the environment a free domain is reserved for the run (:mod:`.domain`); a domain
    where nodes of another run are alive is refused (:class:`DomainBusyError`).

    ``node_params`` maps a node's log name (recorder, planner, controller, simulator)
    to extra ``NAME:=VALUE`` parameters for it. ``plant``: ``sim`` starts
    ``rigid_body_sim``; ``external`` starts no plant and waits up to ``plant_timeout_s``
    for one (a hardware-in-the-loop bridge) to publish the state.
    """
    if plant not in PLANTS:
        raise ValueError(f"plant must be one of {list(PLANTS)}, got {plant!r}")
    started = [n for n in graph.NODES if plant == PLANT_SIM or n is not graph.SIMULATOR]
    extra = {
        name: [arg for p in (node_params or {}).get(name, ()) for arg in ("-p", p)]
        for name in ROLES
    }
    wall0 = time.monotonic()
    scenario = load_scenario(scenario_path)
    check_node_params(scenario_path, node_params or {}, started)  # before anything is written
    out = check_replaceable(out_dir, ("summary.json", "bag"), "run directory")
    env = ros_environment(workspace)
    ros2 = shutil.which("ros2", path=env["PATH"])
    if ros2 is None:
        raise RunError("no `ros2` command on PATH (run `bash tools/bootstrap`)")
    namespace = namespace or run_identity.run_namespace()
    reservation = claim_domain(env, sys.executable)  # DomainBusyError: nothing written
    if timeout_s is None:  # an external plant may run in real time in either mode
        paced = time_mode == "realtime" or plant == PLANT_EXTERNAL
        timeout_s = 120.0 + (1.5 * scenario.sim_time_s if paced else 0.0)
    for line in salvage_stale_runs(out, STAGE_PREFIX):  # left by a run that died
        print(f"attitude-run: {line}", file=sys.stderr, flush=True)
    try:
        tmp = stage(out, STAGE_PREFIX, RUN_MIN_FREE_BYTES)  # OutputDirError: nothing written
        try:
            (tmp / "logs").mkdir()
            shutil.copyfile(scenario_path, tmp / "scenario.yaml")
        except OSError as err:
            shutil.rmtree(tmp, ignore_errors=True)
            raise OutputDirError(f"--out {out}: cannot write in {tmp}: {err.strerror}") from None
    except OutputDirError:
        if reservation is not None:
            reservation.release()
        raise
    params = ["--params-file", str(Path(scenario_path).resolve())]
    # In the scenario's directory: relative data paths resolve as load_scenario does.
    nodes = NodeGraph(ros2, env, tmp / "logs", Path(scenario_path).resolve().parent)
    end_reason, failure = None, None
    stop_requested = []
    handlers = {
        s: signal.signal(s, lambda n, f: stop_requested.append(n))
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        ending = ",".join(status.value for status in PlannerStatus.ending())
        wait_for_plant_s = float(plant_timeout_s) if plant == PLANT_EXTERNAL else 0.0
        own_args = {
            graph.RECORDER.role: [
                "-p",
                f"output_dir:={tmp / 'bag'}",
                "-p",
                f"stop_on_planner_status:=[{ending}]",
                "-p",
                f"stop_delay_s:={float(settle_s)!r}",
                "-p",
                f"scenario_file:={tmp / 'scenario.yaml'}",
                "-p",
                f"plant_timeout_s:={wait_for_plant_s!r}",
            ],
            graph.SIMULATOR.role: [
                "-p",
                f"time_mode:={time_mode}",
                "-p",
                f"lockstep.expected_subscribers:={graph.state_listeners()}",
            ],
        }
        for spec in started:  # in start order
            scenario_args = params if spec.parameters.scenario is not None else []
            nodes.start(
                spec,
                ["-r", f"__ns:={namespace}"]
                + scenario_args
                + own_args.get(spec.role, [])
                + extra[spec.role],
            )
        log(
            f"attitude-run: {scenario.name}: nodes started ({time_mode}) in {namespace} on "
            f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}; logs in {out / 'logs'}"
        )
        if plant == PLANT_EXTERNAL:
            log(
                f"attitude-run: waiting up to {plant_timeout_s:g} s for an external plant on "
                f"{ATTITUDE} (ROS_DOMAIN_ID={env.get('ROS_DOMAIN_ID', '0')}); start it with "
                f"-r __ns:={namespace} "
                f"--params-file {Path(scenario_path).resolve()} -p time_mode:={time_mode} "
                f"-p lockstep.expected_subscribers:={graph.state_listeners()}"
            )
        while end_reason is None:
            time.sleep(0.02)
            exited = nodes.exited()
            if stop_requested:
                end_reason = failure = "interrupted"
            elif exited.get(graph.RECORDER.role) == 0:
                end_reason = "recording complete"  # planner finished or scenario time ended
            elif exited.get(graph.RECORDER.role) == EXIT_NO_PLANT:
                end_reason = failure = f"no plant published {ATTITUDE} within {plant_timeout_s:g} s"
            elif exited.get(graph.SIMULATOR.role) == 0:
                end_reason = "scenario time ended"
            elif exited:
                name, code = next(iter(exited.items()))
                end_reason = failure = guard_failure(code, nodes.log_dir / f"{name}.log") or (
                    f"{name} exited with code {code}"
                )
            elif time.monotonic() - wall0 > timeout_s:
                end_reason = failure = f"timeout after {timeout_s:.0f} s"
    finally:
        stop_t0 = time.monotonic()
        loop, observers = graph.STOP_ORDER
        codes = nodes.stop([n.role for n in loop if n in started], NODE_GRACE_S)
        codes.update(nodes.stop([n.role for n in observers], RECORDER_GRACE_S))
        shutdown_s = time.monotonic() - stop_t0
        for s, h in handlers.items():
            signal.signal(s, h)
        if reservation is not None:
            reservation.release()
    foreign = foreign_publishers_logged(nodes.log_dir)
    if foreign and not failure:  # seen by a node that does not stop on it (the recorder)
        failure = "foreign publisher: " + "; ".join(foreign)
    wall_s = time.monotonic() - wall0
    if failure:
        for name in nodes.exited():
            if nodes.procs[name].returncode not in (0, -signal.SIGINT):
                log(
                    f"attitude-run: {name} (exit {nodes.procs[name].returncode}):\n"
                    + nodes.tail(name)
                )
    recovery, recovery_error = None, None
    if (tmp / "bag").is_dir():  # a recorder killed or out of disk leaves the bag unfinished
        try:
            recovery = recover_bag(str(tmp / "bag"))
        except (NotABagError, OSError) as err:
            recovery_error = f"bag not recoverable: {err}"
        if recovery is not None and recovery.recovered:
            log(f"attitude-run: {describe(recovery)}")
        failure = run_failure(
            failure, recovery, recovery_error, codes.get(graph.RECORDER.role), str(tmp), str(out)
        )
    summary = None
    if (tmp / "bag" / "metadata.yaml").exists():
        try:
            bag_run = run_from_bag(str(tmp / "bag"), scenario, wall_time_s=wall_s)
        except (ValueError, OSError) as err:
            failure = failure or f"bag unusable: {err}"
        else:
            if end_reason == "recording complete":
                codes_seen = set(bag_run.run.planner_status.tolist())
                ended = any(s.code in codes_seen for s in PlannerStatus.ending())
                end_reason = "planner finished" if ended else "scenario time ended"
            summary = summarize_bag(bag_run)
            summary.update(
                {
                    "time_mode": time_mode,
                    "plant": plant,
                    "end_reason": end_reason,
                    "failure": failure,
                    "exit_codes": codes,
                    "shutdown_s": round(shutdown_s, 3),
                    "run_namespace": namespace,
                    "ros_domain_id": int(env["ROS_DOMAIN_ID"]),
                    "foreign_publishers": foreign,
                }
            )
            summary.update(run_fields(recovery, str(tmp / "bag"), bag_run.run.t))
            with open(tmp / "summary.json", "w") as f:
                dump_strict(summary, f, indent=2)  # NaN/inf -> null, named in non_finite
    if summary is None:  # no step recorded: the failure is still named in summary.json
        with open(tmp / "summary.json", "w") as f:
            dump_strict(
                {
                    "scenario": scenario.name,
                    "reached": False,
                    "min_margin_deg": None,
                    "steps_recorded": 0,
                    "time_mode": time_mode,
                    "plant": plant,
                    "end_reason": end_reason,
                    "failure": f"{failure or end_reason}; no usable bag",
                    "exit_codes": codes,
                    "shutdown_s": round(shutdown_s, 3),
                    "run_namespace": namespace,
                    "ros_domain_id": int(env["ROS_DOMAIN_ID"]),
                    "foreign_publishers": foreign,
                },
                f,
                indent=2,
            )
    refused = [  # nodes that refused their input (a check attitude-run could not make)
        f"{n} exited with code 2: {nodes.error_line(n)}"
        for n, c in codes.items()
        if c == NODE_EXIT_BAD_INPUT
    ]
    publish(tmp, out)  # also after a failure: what was recorded is kept
    if refused:
        raise NodeInputError("; ".join(refused) + f" (logs in {out / 'logs'})")
    if summary is None:
        raise RunError(f"{failure or end_reason}; no usable bag (logs in {out / 'logs'})")
    return summary, out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-run",
        description="Run a scenario through the ROS 2 nodes (planner, controller, simulator) "
        "and record it to a rosbag2 MCAP bag.",
    )
    parser.add_argument("scenario", help="scenario YAML (ROS 2 parameters file)")
    parser.add_argument(
        "--out", required=True, help="run directory to write (bag/, logs/, summary.json)"
    )
    parser.add_argument(
        "--mode",
        choices=("lockstep", "realtime"),
        default="lockstep",
        help="lockstep simulated time (default) or wall-clock real time",
    )
    parser.add_argument(
        "--timeout-s",
        type=float,
        default=None,
        help="wall-time limit (default 120 s, plus 1.5x the scenario time in real time)",
    )
    parser.add_argument(
        "--settle-s",
        type=float,
        default=10.0,
        help="run time recorded after the planner reports a status that "
        f"ends the slew ({', '.join(PlannerStatus.ending())}), s "
        "(default 10: the body settles on the goal)",
    )
    parser.add_argument(
        "--workspace",
        default=None,
        help="colcon install/ directory (default: this checkout's ros2_ws/install)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NODE:NAME:=VALUE",
        help="extra parameter for one node (recorder, planner, controller, "
        "simulator), e.g. simulator:lockstep.torque_timeout_s:=0.5",
    )
    parser.add_argument(
        "--plant",
        choices=PLANTS,
        default=PLANT_SIM,
        help="sim (default): start rigid_body_sim; external: start no plant and wait for "
        "one (a hardware-in-the-loop bridge) to publish the state (docs/hil_bridge.md)",
    )
    parser.add_argument(
        "--plant-timeout-s",
        type=float,
        default=60.0,
        help="with --plant external: fail when no state arrives within this wall time, s "
        "(default 60)",
    )
    parser.add_argument(
        "--run-namespace",
        default=None,
        metavar="NS",
        help="ROS namespace of the run's nodes (default: a fresh /attitude_run_<id>); "
        "an external plant joins the run with `-r __ns:=NS`",
    )
    parser.add_argument("--quiet", action="store_true", help="do not print the summary")
    args = parser.parse_args(argv)
    if args.run_namespace is not None and not run_identity.in_run(args.run_namespace):
        prefix = "/" + run_identity.RUN_NAMESPACE_PREFIX
        parser.error(
            f"--run-namespace {args.run_namespace!r}: must start with {prefix!r} "
            f"(e.g. {prefix}hil1)"
        )
    if not 0.0 < args.plant_timeout_s <= 3600.0:
        parser.error(f"--plant-timeout-s: must be in (0, 3600], got {args.plant_timeout_s!r}")
    node_params: dict[str, list[str]] = {}
    for item in args.param:
        node, _, assignment = item.partition(":")
        if node not in ROLES or ":=" not in assignment:
            parser.error(
                f"--param {item!r}: expected NODE:NAME:=VALUE with NODE one of {list(ROLES)}"
            )
        node_params.setdefault(node, []).append(assignment)
    if args.plant == PLANT_EXTERNAL and graph.SIMULATOR.role in node_params:
        parser.error("--param simulator:...: no simulator is started with --plant external")
    log: Callable[[str], None] = (
        (lambda *a: None) if args.quiet else (lambda msg: print(msg, flush=True))
    )
    try:
        summary, out = run_scenario(
            args.scenario,
            args.out,
            args.mode,
            args.timeout_s,
            args.workspace,
            args.settle_s,
            log,
            node_params,
            plant=args.plant,
            plant_timeout_s=args.plant_timeout_s,
            namespace=args.run_namespace,
        )
    except (
        ParameterError,
        OutputDirError,
        FileExistsError,
        NodeInputError,
        DomainBusyError,
        NoFreeDomain,
    ) as err:
        print(f"attitude-run: error: {err}", file=sys.stderr)  # bad input: --param, --out
        return 2
    except RunError as err:
        print(f"attitude-run: error: {err}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(dumps_strict(summary, indent=2))
    if summary["planner_infeasible"]:
        print(f"attitude-run: infeasible: {summary['infeasible_reason']}", file=sys.stderr)
        return 1
    ok = summary["reached"] and summary["min_margin_deg"] > 0.0 and not summary["failure"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
