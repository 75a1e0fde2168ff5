"""``attitude-run SCENARIO.yaml --out DIR``: one scenario through the ROS 2 node graph.

Starts the recorder, the planner, the controller and the simulator as separate
processes, each the executable ``ros2 run <package> <executable> --ros-args ...`` runs
(found in the ament index as ros2run and launch_ros find it, started directly), waits until the
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
SIGKILL (:mod:`.processes`); a staging directory left by a killed run is recovered
or cleaned by the next run into ``DIR`` (:mod:`.stale`).

This module is the command line and :func:`run_scenario`, which takes the steps of
:mod:`.orchestrate` in order; the node processes are :mod:`.graph`'s, their
environment :mod:`.environment`'s.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from attitude_core.config import node_graph as graph
from attitude_core.config.parameters import ParameterError
from attitude_core.contract.status import PlannerStatus
from attitude_core.runtime.run_identity import namespace_error, node_name_error
from attitude_tools.output.rundir import OutputDirError
from attitude_tools.output.strict_json import dumps_strict
from attitude_tools.run.domain import DomainBusyError, NoFreeDomain
from attitude_tools.run.environment import default_workspace, ros_environment
from attitude_tools.run.errors import NodeInputError, RunError
from attitude_tools.run.graph import NodeGraph
from attitude_tools.run.orchestrate import (
    PLANT_EXTERNAL,
    PLANT_SIM,
    PLANTS,
    ROLES,
    RunRequest,
    after_stop,
    check_inputs,
    no_bag_summary,
    publish_run,
    run_nodes,
    stage_run,
    summarize_run,
    write_summary,
)

__all__ = [  # NodeGraph, the errors and the environment re-exported for the tests
    "PLANTS",
    "PLANT_EXTERNAL",
    "PLANT_SIM",
    "ROLES",
    "NodeGraph",
    "NodeInputError",
    "RunError",
    "default_workspace",
    "main",
    "ros_environment",
    "run_scenario",
]


def run_scenario(
    scenario_path: str,
    out_dir: str,
    time_mode: str = "lockstep",
    timeout_s: float | None = None,
    workspace: str | None = None,
    settle_s: float = 10.0,
    log: Callable[[str], None] = print,
    node_params: dict[str, list[str]] | None = None,
    plant: str = PLANT_SIM,
    plant_timeout_s: float = 60.0,
    namespace: str | None = None,
    external_estimate: bool = False,
    plant_nodes: tuple[str, ...] = (),
    hold: bool = False,
    until_stopped: bool = False,
) -> tuple[dict[str, Any], Path]:
    """Run one scenario through the node graph; return (summary, run directory).

    Every node is started in the run's namespace (``namespace``, default a fresh
    ``/attitude_run_<id>``; :mod:`attitude_core.runtime.run_identity`). Without ``ROS_DOMAIN_ID``
    in the environment a free domain is reserved for the run (:mod:`.domain`); a domain
    where nodes of another run are alive is refused (:class:`DomainBusyError`).

    ``node_params`` maps a node's log name (recorder, planner, controller, simulator)
    to extra ``NAME:=VALUE`` parameters for it. ``plant``: ``sim`` starts
    ``rigid_body_sim``; ``external`` starts no plant and waits up to ``plant_timeout_s``
    for one (a hardware-in-the-loop bridge) to publish the state. With a scenario that
    declares ``sensors.*`` the estimator node runs on the plant's measurements, unless
    ``external_estimate`` (an external plant that publishes its own estimate).
    ``plant_nodes``: the external plant's nodes by name (any namespace; default: the
    single node publishing both state topics is adopted). The nodes are managed: the
    run's lifecycle manager configures them, checks the run, activates them in start
    order (``hold``: only when the operator sends SIGUSR1) and brings them down in
    reverse. ``until_stopped``: the run does not end on arrival (nor, with a plan, on its
    completion): it flies the goals it is sent on ``<namespace>/planner/goal`` until
    SIGINT or SIGTERM (or the scenario's ``sim_time_s``), then ends as usual.
    """
    req = RunRequest(
        scenario_path=scenario_path,
        out_dir=out_dir,
        time_mode=time_mode,
        timeout_s=timeout_s,
        settle_s=settle_s,
        log=log,
        node_params=node_params or {},
        plant=plant,
        plant_timeout_s=plant_timeout_s,
        namespace=namespace,
        external_estimate=external_estimate,
        plant_nodes=plant_nodes,
        hold=hold,
        until_stopped=until_stopped,
    )
    inputs = check_inputs(req)  # nothing written or started before this passes
    staged = stage_run(req, inputs, ros_environment(workspace))
    # In the scenario's directory: relative data paths resolve as load_scenario does.
    nodes = NodeGraph(
        staged.env, staged.tmp / "logs", Path(scenario_path).resolve().parent, staged.executables
    )
    end = run_nodes(req, inputs, staged, nodes)
    after_stop(req, inputs, staged, nodes, end)
    summary = summarize_run(req, inputs, staged, end)
    write_summary(
        staged.tmp, summary if summary is not None else no_bag_summary(req, inputs, staged, end)
    )
    return publish_run(nodes, staged, inputs.out, end, summary), inputs.out


def _parser() -> argparse.ArgumentParser:
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
        help="extra parameter for one node (recorder, estimator, planner, controller, "
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
        help="ROS namespace of the run's nodes, any but the root (default: a fresh "
        "/attitude_run_<id>); an external plant joins the run with `-r __ns:=NS`, or "
        "is named with --plant-node",
    )
    parser.add_argument(
        "--plant-node",
        action="append",
        default=[],
        metavar="NODE",
        help="with --plant external: the plant's node, fully qualified, in any namespace "
        "(e.g. /bsk_bridge); repeat it for a plant split over several nodes. Only they "
        "may publish the plant's topics. Default: adopt the single node that publishes "
        "both state topics (named on stderr and in summary.json, plant_node)",
    )
    parser.add_argument(
        "--hold",
        action="store_true",
        help="stop after configure and the checks (fingerprints, plant present) and wait "
        "for the operator: `kill -USR1 <attitude-run pid>` activates the nodes",
    )
    parser.add_argument(
        "--external-estimate",
        action="store_true",
        help="with --plant external and a scenario with sensors.*: the plant publishes its "
        "own estimate on /spacecraft/attitude and /spacecraft/angular_velocity, so no "
        "estimator is started (default: the plant publishes the raw sensors and the "
        "estimator node filters them; docs/hil_bridge.md)",
    )
    parser.add_argument(
        "--until-stopped",
        action="store_true",
        help="do not end on arrival (nor on a plan's completion): fly the goals sent on "
        "<run namespace>/planner/goal (geometry_msgs/QuaternionStamped, frame inertial) "
        "until SIGINT or SIGTERM, or the scenario's sim_time_s; then stop the nodes, close "
        "the bag and write summary.json (goals: each goal and its outcome); exit 0 if the "
        "body never entered a keep-out",
    )
    parser.add_argument("--quiet", action="store_true", help="do not print the summary")
    return parser


def _node_params(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict[str, list[str]]:
    """Check the arguments argparse cannot; each node's ``--param`` items, by role."""
    reason = None if args.run_namespace is None else namespace_error(args.run_namespace)
    if reason is not None:
        parser.error(f"--run-namespace {args.run_namespace!r}: {reason}")
    for name in args.plant_node:
        if (why := node_name_error(name)) is not None:
            parser.error(f"--plant-node {name!r}: {why}")
    if args.plant_node and args.plant != PLANT_EXTERNAL:
        parser.error("--plant-node: needs --plant external (the simulator is the run's own)")
    if len(set(args.plant_node)) != len(args.plant_node):
        parser.error(f"--plant-node: a node named twice in {args.plant_node}")
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
    if args.external_estimate and args.plant != PLANT_EXTERNAL:
        parser.error(
            "--external-estimate: needs --plant external (the simulator's sensors "
            "are always filtered by the estimator)"
        )
    if args.plant == PLANT_EXTERNAL and graph.SIMULATOR.role in node_params:
        parser.error("--param simulator:...: no simulator is started with --plant external")
    return node_params


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    node_params = _node_params(parser, args)
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
            external_estimate=args.external_estimate,
            plant_nodes=tuple(args.plant_node),
            hold=args.hold,
            until_stopped=args.until_stopped,
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
    ok = _succeeded(summary, args.until_stopped)
    if not ok:  # said on stderr even with --quiet: a failed run never ends silently
        print(f"attitude-run: failed: {_failure_line(summary)}", file=sys.stderr)
    return 0 if ok else 1


def _succeeded(summary: dict[str, Any], until_stopped: bool) -> bool:
    """A finished run's success: no keep-out entered on the body and no failure; and,
    unless stopped by the operator, the goal reached, or with goals every one of them
    reached, refused or infeasible (a plan's skipped targets are on record)."""
    safe = summary["min_margin_deg"] > 0.0 and not summary["failure"]
    if until_stopped or not safe:
        return safe
    from attitude_core.record.goal_figures import goals_settled  # after the run: lazily

    goals = summary.get("goals") or []
    return goals_settled(goals) if goals else bool(summary["reached"])


def _failure_line(summary: dict[str, Any]) -> str:
    """Why a finished run is a failure, from its summary."""
    if summary["failure"]:
        return str(summary["failure"])
    goals = summary.get("goals") or []
    from attitude_core.record.goal_figures import SETTLED_OUTCOMES

    missed = [g for g in goals if g["outcome"] not in SETTLED_OUTCOMES]
    if missed:
        return f"goal {missed[0]['name']} {missed[0]['outcome']} ({summary['end_reason']})"
    if not summary["reached"]:
        return f"goal not reached ({summary['end_reason']})"
    return f"keep-out margin {summary['min_margin_deg']} deg on the body"


if __name__ == "__main__":
    sys.exit(main())
