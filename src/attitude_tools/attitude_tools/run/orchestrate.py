"""The steps of one ``attitude-run``, in the order
:func:`attitude_tools.run.cli.run_scenario` takes them:

1. :func:`check_inputs`: the scenario, ``--param`` and ``--out``, before anything is
   written or started;
2. :func:`stage_run`: the nodes' executables, the run's namespace and domain, the
   wall-time limit,
   the staging directory beside ``--out`` (stale ones salvaged first);
3. :func:`run_nodes`: start the nodes, wait for the end of the run, stop them;
4. :func:`after_stop`: foreign publishers, the failed nodes' logs, the bag recovered;
5. :func:`summarize_run` and :func:`write_summary`: ``summary.json`` from the bag alone
   (:func:`no_bag_summary` without a usable bag);
6. :func:`publish_run`: the staging directory replaces ``--out``, also after a failure.
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import sys
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from attitude_core.config import node_graph as graph
from attitude_core.config.node_graph import NodeSpec
from attitude_core.config.scenario import Scenario, ScenarioError
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.faults import FaultKind
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import ANGULAR_VELOCITY, ATTITUDE, IMU, STAR_TRACKER
from attitude_core.runtime import run_identity
from attitude_core.runtime.recording import EXIT_NO_PLANT
from attitude_core.runtime.shm_segments import sweep_orphan_segments
from attitude_tools.bag.recovery import (
    NotABagError,
    Recovery,
    describe,
    recover_bag,
    run_failure,
    run_fields,
)
from attitude_tools.output.rundir import OutputDirError, check_replaceable, publish, stage
from attitude_tools.output.strict_json import dump_strict
from attitude_tools.run.domain import DomainReservation, claim_domain
from attitude_tools.run.environment import node_executables
from attitude_tools.run.errors import NodeInputError, RunError
from attitude_tools.run.graph import NodeGraph
from attitude_tools.run.guard_report import foreign_publishers_logged, guard_failure
from attitude_tools.run.manager_link import ManagerLink
from attitude_tools.run.node_params import check_node_params
from attitude_tools.run.stale import salvage_stale_runs

__all__ = [
    "NODE_EXIT_BAD_INPUT",
    "NODE_GRACE_S",
    "PLANTS",
    "PLANT_EXTERNAL",
    "PLANT_SIM",
    "RECORDER_GRACE_S",
    "ROLES",
    "RUN_MIN_FREE_BYTES",
    "STAGE_PREFIX",
    "CheckedInputs",
    "RunEnd",
    "RunRequest",
    "StagedRun",
    "after_stop",
    "check_inputs",
    "no_bag_summary",
    "publish_run",
    "run_nodes",
    "stage_run",
    "summarize_run",
    "write_summary",
]

ROLES = tuple(n.role for n in graph.SENSING_NODES)
PLANT_SIM, PLANT_EXTERNAL = "sim", "external"
PLANTS = (PLANT_SIM, PLANT_EXTERNAL)
# Shutdown budget, 5 s in all: the nodes first, then the recorder (which drains its
# queues for up to 1.5 s and finishes the bag).
NODE_GRACE_S, RECORDER_GRACE_S = 1.5, 3.0
MANAGER_GRACE_S = 6.0  # the lifecycle bring-down: deactivate, shutdown, the bag drained
STAGE_PREFIX = ".tmp-run-"
RUN_MIN_FREE_BYTES = 64 * 2**20  # free beside --out before a run starts (bags are MBs)
NODE_EXIT_BAD_INPUT = 2  # attitude_ros.runner.EXIT_BAD_INPUT


@dataclass(frozen=True)
class RunRequest:
    """What the caller of ``run_scenario`` asked for (``node_params``: never None)."""

    scenario_path: str
    out_dir: str
    time_mode: str
    timeout_s: float | None
    settle_s: float
    log: Callable[[str], None]
    node_params: dict[str, list[str]]
    plant: str
    plant_timeout_s: float
    namespace: str | None
    external_estimate: bool = False  # an external plant feeds its own estimate
    plant_nodes: tuple[str, ...] = ()  # an external plant's nodes, named (any namespace)
    hold: bool = False  # stop after configure and the checks until the operator says go
    until_stopped: bool = False  # no end on arrival: goals until SIGINT/SIGTERM (or sim time)


@dataclass(frozen=True)
class CheckedInputs:
    """The inputs, checked before anything is written or started."""

    scenario: Scenario
    out: Path
    started: list[NodeSpec[Any]]  # the nodes this run starts, in start order
    nodes: graph.Graph  # the run's node graph (with the estimator when sensing)
    extra: dict[str, list[str]]  # each role's ``--param`` items as ``-p NAME:=VALUE``
    wall0: float  # monotonic time the run began


@dataclass(frozen=True)
class StagedRun:
    """The run made ready: the nodes' environment (``ROS_DOMAIN_ID`` set), their
    executables (by role), namespace, domain reservation, wall-time limit and staging
    directory."""

    env: dict[str, str]
    executables: dict[str, str]
    namespace: str
    reservation: DomainReservation | None
    timeout_s: float
    tmp: Path


@dataclass
class Bringup:
    """What the run's lifecycle manager reported: the plant's nodes (named or adopted)."""

    link: ManagerLink | None = None
    plant_nodes: list[str] = field(default_factory=list)
    adopted: bool = False
    held_s: float = 0.0  # wall time held before activation (not counted in the limit)


@dataclass
class RunEnd:
    """How the run ended, as far as known: the later steps may name a failure."""

    end_reason: str
    failure: str | None
    codes: dict[str, int]  # exit code of each node, by role
    shutdown_s: float
    foreign: list[str] = field(default_factory=list)  # foreign publishers the nodes logged
    bringup: Bringup = field(default_factory=Bringup)
    wall_s: float = float("nan")
    recovery: Recovery | None = None
    rebuilt: Future[Any] | None = None  # the run from the bag, rebuilt during bring-down


# -- 1. check the inputs ---------------------------------------------------------------


def check_inputs(req: RunRequest) -> CheckedInputs:
    """Load the scenario, check ``--param`` and ``--out``; nothing written or started."""
    if req.plant not in PLANTS:
        raise ValueError(f"plant must be one of {list(PLANTS)}, got {req.plant!r}")
    if req.external_estimate and req.plant != PLANT_EXTERNAL:
        raise ValueError("an external estimate needs an external plant (--plant external)")
    extra = {
        name: [arg for p in req.node_params.get(name, ()) for arg in ("-p", p)] for name in ROLES
    }
    wall0 = time.monotonic()
    scenario = load_scenario(req.scenario_path)
    if req.external_estimate and scenario.sensors is None:
        raise ScenarioError(
            req.scenario_path,
            "sensors",
            "missing: an external estimate needs the sensors it comes from (sensors.*: the "
            "guidance's knowledge bounds)",
        )
    nodes = graph.graph(
        scenario.sensors is not None and not req.external_estimate, scenario.wheels is not None
    )
    started = [n for n in nodes.nodes if req.plant == PLANT_SIM or n.role != graph.SIMULATOR.role]
    check_node_params(req.scenario_path, req.node_params, started)  # before anything is written
    out = check_replaceable(req.out_dir, ("summary.json", "bag"), "run directory")
    return CheckedInputs(scenario, out, started, nodes, extra, wall0)


# -- 2. prepare the output and the domain ----------------------------------------------


def stage_run(req: RunRequest, inputs: CheckedInputs, env: dict[str, str]) -> StagedRun:
    """Find the nodes' executables, claim the run's domain (in ``env``), salvage stale
    staging directories, stage the run's directory beside ``--out``."""
    executables = node_executables(env, [*inputs.started, graph.MANAGER])  # RunError
    namespace = req.namespace or run_identity.run_namespace()
    reservation = claim_domain(env, sys.executable)  # DomainBusyError: nothing written
    sweep_orphan_segments()  # Fast DDS segments of node processes that are gone
    timeout_s = req.timeout_s
    if timeout_s is None and req.until_stopped:  # the operator ends it (or the sim time)
        timeout_s = math.inf
    if timeout_s is None:  # an external plant may run in real time in either mode
        paced = req.time_mode == "realtime" or req.plant == PLANT_EXTERNAL
        timeout_s = 120.0 + (1.5 * inputs.scenario.sim_time_s if paced else 0.0)
    for line in salvage_stale_runs(inputs.out, STAGE_PREFIX):  # left by a run that died
        print(f"attitude-run: {line}", file=sys.stderr, flush=True)
    try:
        tmp = _stage_directory(req.scenario_path, inputs.out)
    except OutputDirError:
        if reservation is not None:
            reservation.release()
        raise
    return StagedRun(env, executables, namespace, reservation, timeout_s, tmp)


def _stage_directory(scenario_path: str, out: Path) -> Path:
    """The staging directory beside ``out``, holding ``logs/`` and ``scenario.yaml``."""
    tmp = stage(out, STAGE_PREFIX, RUN_MIN_FREE_BYTES)  # OutputDirError: nothing written
    try:
        (tmp / "logs").mkdir()
        shutil.copyfile(scenario_path, tmp / "scenario.yaml")
    except OSError as err:
        shutil.rmtree(tmp, ignore_errors=True)
        raise OutputDirError(f"--out {out}: cannot write in {tmp}: {err.strerror}") from None
    return tmp


# -- 3. start the nodes, wait for the end, stop them -----------------------------------


def run_nodes(
    req: RunRequest, inputs: CheckedInputs, staged: StagedRun, nodes: NodeGraph
) -> RunEnd:
    """Start the nodes, wait for the end of the run, stop them (also on an exception;
    the domain is released then). SIGINT or SIGTERM meanwhile ends the run as
    interrupted."""
    stop_requested: list[int] = []
    handlers = {
        s: signal.signal(s, lambda n, f: stop_requested.append(n))
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    bringup = Bringup()
    go: list[int] = []  # SIGUSR1: activate after --hold
    handlers[signal.SIGUSR1] = signal.signal(signal.SIGUSR1, lambda n, f: go.append(n))
    try:
        bringup.link = _start_nodes(req, inputs, staged, nodes)
        _preload()
        end_reason, failure = _wait_for_end(req, inputs, staged, nodes, stop_requested, bringup, go)
        rebuilt = _rebuild(staged, inputs) if end_reason == "recording complete" else None
    finally:
        codes, shutdown_s = _stop_nodes(nodes, inputs.started, inputs.nodes, bringup.link)
        for s, h in handlers.items():
            signal.signal(s, h)
        if staged.reservation is not None:
            staged.reservation.release()
    return RunEnd(end_reason, failure, codes, shutdown_s, bringup=bringup, rebuilt=rebuilt)


def _rebuild(staged: StagedRun, inputs: CheckedInputs) -> Future[Any]:
    """The run rebuilt from its bag on a thread, from the moment the recorder has closed
    the bag (it exited 0) while the nodes are brought down: about 0.1 s off the end of
    the run. :func:`summarize_run` takes it unless the bag had to be recovered."""
    import threading

    future: Future[Any] = Future()

    def rebuild() -> None:
        from attitude_tools.bag.run_record import run_from_bag

        try:
            future.set_result(run_from_bag(str(staged.tmp / "bag"), inputs.scenario))
        except Exception as err:  # noqa: BLE001 -- every error to summarize_run (result() raises it)
            future.set_exception(err)

    threading.Thread(target=rebuild, name="rebuild", daemon=True).start()
    return future


def _preload() -> None:
    """Import the summary's modules (the bag reader and the metrics, about 0.1 s) in a
    thread while the nodes run, not before they start nor after they end."""
    import importlib
    import threading

    def load() -> None:
        importlib.import_module("attitude_tools.bag.run_record")

    threading.Thread(target=load, name="preload", daemon=True).start()


def stop_statuses(req: RunRequest, scenario: Scenario) -> tuple[PlannerStatus, ...]:
    """The planner statuses that end the recording (after ``--settle-s``): every
    ending status of a single slew; with a plan, its completion (or safe mode); with
    ``--until-stopped``, none (the operator ends the run)."""
    if req.until_stopped:
        return ()
    if scenario.plan:
        return (PlannerStatus.COMPLETE, PlannerStatus.SAFE_MODE)
    return PlannerStatus.ending()


def _own_args(
    req: RunRequest, tmp: Path, nodes: graph.Graph, scenario: Scenario
) -> dict[str, list[str]]:
    """The parameters ``attitude-run`` sets itself: the recorder's and the simulator's."""
    ending = _string_list([status.value for status in stop_statuses(req, scenario)])
    wait_for_plant_s = float(req.plant_timeout_s) if req.plant == PLANT_EXTERNAL else 0.0
    return {
        graph.RECORDER.role: [
            "-p",
            f"output_dir:={tmp / 'bag'}",
            "-p",
            f"stop_on_planner_status:={ending}",
            "-p",
            f"stop_delay_s:={float(req.settle_s)!r}",
            "-p",
            f"scenario_file:={tmp / 'scenario.yaml'}",
            "-p",
            f"plant_timeout_s:={wait_for_plant_s!r}",
        ],
        graph.SIMULATOR.role: [
            "-p",
            f"time_mode:={req.time_mode}",
            "-p",
            f"lockstep.expected_subscribers:={graph.state_listeners(nodes.nodes)}",
        ],
    }


def _string_list(values: list[str] | tuple[str, ...]) -> str:
    return "[" + ",".join(values) + "]" if values else "['']"


def _node_names(namespace: str, started: list[NodeSpec[Any]]) -> dict[str, str]:
    """Role -> fully qualified name of each started node, in start order."""
    return {spec.role: f"{namespace.rstrip('/')}/{spec.node_name}" for spec in started}


def _manager_args(
    req: RunRequest, inputs: CheckedInputs, namespace: str, names: dict[str, str]
) -> list[str]:
    """The lifecycle manager's parameters: the nodes ``names`` (role -> fully qualified
    name, :func:`_node_names`) in activation order, the plant."""
    if req.plant == PLANT_SIM:
        plants: tuple[str, ...] = (names[graph.SIMULATOR.role],)
    else:
        plants = req.plant_nodes
    topics = (IMU, STAR_TRACKER) if inputs.nodes.sensing else (ATTITUDE, ANGULAR_VELOCITY)
    timeout_s = req.plant_timeout_s if req.plant == PLANT_EXTERNAL else 60.0
    return [
        "-r", f"__ns:={namespace}",
        "-p", f"node_names:={_string_list(list(names.values()))}",
        "-p", f"plant_nodes:={_string_list(plants)}",
        "-p", f"plant_topics:={_string_list(list(topics))}",
        "-p", f"plant_timeout_s:={float(timeout_s)!r}",
        "-p", f"hold:={str(req.hold).lower()}",
    ]  # fmt: skip


def _start_nodes(
    req: RunRequest, inputs: CheckedInputs, staged: StagedRun, nodes: NodeGraph
) -> ManagerLink:
    """Start the nodes (unconfigured) in start order, in the run's namespace, then their
    lifecycle manager; say where they run."""
    params = ["--params-file", str(Path(req.scenario_path).resolve())]
    own_args = _own_args(req, staged.tmp, inputs.nodes, inputs.scenario)
    plants = ["-p", f"plant_nodes:={_string_list(req.plant_nodes)}"] if req.plant_nodes else []
    for spec in inputs.started:  # in start order
        scenario_args = params if spec.parameters.scenario is not None else []
        nodes.start(
            spec,
            ["-r", f"__ns:={staged.namespace}"]
            + scenario_args
            + plants
            + own_args.get(spec.role, [])
            + inputs.extra[spec.role],
            autostart=False,
        )
    names = _node_names(staged.namespace, inputs.started)
    link = ManagerLink(
        nodes.start(graph.MANAGER, _manager_args(req, inputs, staged.namespace, names), piped=True),
        names,
    )
    env, namespace, time_mode = staged.env, staged.namespace, req.time_mode
    req.log(
        f"attitude-run: {inputs.scenario.name}: nodes started ({time_mode}) in {namespace} on "
        f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}; logs in {inputs.out / 'logs'}"
    )
    if req.plant == PLANT_EXTERNAL:
        feeds = IMU + " and " + STAR_TRACKER if inputs.nodes.sensing else ATTITUDE
        req.log(
            f"attitude-run: waiting up to {req.plant_timeout_s:g} s for an external plant on "
            f"{feeds} (ROS_DOMAIN_ID={env.get('ROS_DOMAIN_ID', '0')}); start it with "
            f"-r __ns:={namespace} "
            f"--params-file {Path(req.scenario_path).resolve()} -p time_mode:={time_mode} "
            f"-p lockstep.expected_subscribers:={graph.state_listeners(inputs.nodes.nodes)}"
            " (or in any namespace, named with --plant-node)"
        )
    return link


def _wait_for_end(
    req: RunRequest,
    inputs: CheckedInputs,
    staged: StagedRun,
    nodes: NodeGraph,
    stop_requested: list[int],
    bringup: Bringup,
    go: list[int],
) -> tuple[str, str | None]:
    """Poll the nodes and their manager until the run ends; (end reason, failure or None)."""
    held_since: float | None = None
    while True:
        time.sleep(0.02)
        exited = nodes.exited()
        for event in bringup.link.events() if bringup.link is not None else []:
            kind = event["event"]
            if kind == "failure":
                return str(event["reason"]), str(event["reason"])
            if kind == "plant":
                _adopted(req, bringup, event)
            elif kind == "holding":
                held_since = time.monotonic()
                req.log(
                    f"attitude-run: configured and checked, holding before activation; "
                    f"activate with `kill -USR1 {os.getpid()}`"
                )
            elif kind == "active" and held_since is not None:
                bringup.held_s += time.monotonic() - held_since
                held_since = None
        if go and bringup.link is not None:
            go.clear()
            bringup.link.send("activate")
        held = bringup.held_s + (time.monotonic() - held_since if held_since else 0.0)
        if stop_requested and req.until_stopped:
            return "stopped by the operator", None
        if stop_requested:
            return "interrupted", "interrupted"
        elif exited.get(graph.RECORDER.role) == 0:
            return "recording complete", None  # planner finished or scenario time ended
        elif exited.get(graph.RECORDER.role) == EXIT_NO_PLANT:
            failure = f"no plant published {ATTITUDE} within {req.plant_timeout_s:g} s"
            return failure, failure
        elif exited.get(graph.SIMULATOR.role) == 0:
            return "scenario time ended", None
        elif exited:
            name, code = next(iter(exited.items()))
            failure = guard_failure(code, nodes.log_dir / f"{name}.log") or (
                f"{name} exited with code {code}"
            )
            return failure, failure
        elif time.monotonic() - inputs.wall0 - held > staged.timeout_s:
            failure = f"timeout after {staged.timeout_s:.0f} s"
            return failure, failure


def _adopted(req: RunRequest, bringup: Bringup, event: dict[str, Any]) -> None:
    bringup.plant_nodes = [str(n) for n in event.get("nodes", [])]
    bringup.adopted = bool(event.get("adopted"))
    if req.plant == PLANT_EXTERNAL:
        how = "adopted" if bringup.adopted else "named"
        print(
            f"attitude-run: plant {how}: {', '.join(bringup.plant_nodes)}",
            file=sys.stderr,
            flush=True,
        )


def _stop_nodes(
    nodes: NodeGraph,
    started: list[NodeSpec[Any]],
    nodes_graph: graph.Graph,
    link: ManagerLink | None,
) -> tuple[dict[str, int], float]:
    """The manager deactivates and shuts down the nodes in reverse order; then whatever
    is left is stopped as before: the control loop's nodes, then the observers (the
    recorder finishes the bag); (exit codes by role, shutdown time in s)."""
    stop_t0 = time.monotonic()
    loop, observers = nodes_graph.stop_order
    exited = nodes.exited()
    gone = [link.names[n.role] for n in started if n.role in exited] if link else []

    def report_exits() -> None:  # a node that ends now: the manager must not wait on it
        assert link is not None
        ended = {link.names[n.role] for n in started if n.role in nodes.exited()}
        new = sorted(ended.difference(gone))
        if new and link.send(" ".join(["gone", *new])):
            gone.extend(new)

    if (
        link is not None
        and link.send(" ".join(["stop", *gone]))
        and link.wait(MANAGER_GRACE_S, report_exits)
    ):
        nodes.wait_exit([n.role for n in started], NODE_GRACE_S)  # finalized: exiting
    codes = nodes.stop([n.role for n in loop if n in started], NODE_GRACE_S)
    codes.update(nodes.stop([n.role for n in observers], RECORDER_GRACE_S))
    if graph.MANAGER.role in nodes.procs:
        codes.update(nodes.stop([graph.MANAGER.role], NODE_GRACE_S))
    return codes, time.monotonic() - stop_t0


# -- 4. after the stop: foreign publishers, failed nodes, the bag recovered -------------


def after_stop(
    req: RunRequest, inputs: CheckedInputs, staged: StagedRun, nodes: NodeGraph, end: RunEnd
) -> None:
    """Name the foreign publishers the nodes logged, show the logs of failed nodes,
    finish a bag its recorder left unfinished (``end`` updated)."""
    end.foreign = foreign_publishers_logged(nodes.log_dir)
    named = "foreign publisher: " + "; ".join(end.foreign)
    if end.foreign and not end.failure:  # seen by a node that does not stop on it (the recorder)
        end.failure = named
    elif end.foreign and "foreign publisher" not in (end.failure or ""):
        end.failure = f"{named} ({end.failure})"  # the cause first (e.g. a node it stopped)
    end.wall_s = time.monotonic() - inputs.wall0
    if end.failure:
        _log_failed_nodes(req.log, nodes)
    # A recorder killed or out of disk leaves the bag unfinished: finish it.
    if (staged.tmp / "bag").is_dir():
        _recover_bag(req, inputs, staged, end)


def _log_failed_nodes(log: Callable[[str], None], nodes: NodeGraph) -> None:
    """The log tail of each node that exited other than cleanly or on SIGINT."""
    for name in nodes.exited():
        if nodes.procs[name].returncode not in (0, -signal.SIGINT):
            log(f"attitude-run: {name} (exit {nodes.procs[name].returncode}):\n" + nodes.tail(name))


def _recover_bag(req: RunRequest, inputs: CheckedInputs, staged: StagedRun, end: RunEnd) -> None:
    """Finish the bag if its recorder died; the failure then says what happened to it."""
    recovery_error = None
    try:
        end.recovery = recover_bag(str(staged.tmp / "bag"))
    except (NotABagError, OSError) as err:
        recovery_error = f"bag not recoverable: {err}"
    if end.recovery is not None and end.recovery.recovered:
        req.log(f"attitude-run: {describe(end.recovery)}")
    end.failure = run_failure(
        end.failure,
        end.recovery,
        recovery_error,
        end.codes.get(graph.RECORDER.role),
        str(staged.tmp),
        str(inputs.out),
    )


# -- 5. the summary, from the bag alone ------------------------------------------------


def _run_summary_fields(req: RunRequest, staged: StagedRun, end: RunEnd) -> dict[str, Any]:
    """The ``summary.json`` fields of the ROS run itself (after the offline runner's)."""
    return {
        "time_mode": req.time_mode,
        "plant": req.plant,
        "end_reason": end.end_reason,
        "failure": end.failure,
        "exit_codes": end.codes,
        "shutdown_s": round(end.shutdown_s, 3),
        "run_namespace": staged.namespace,
        "ros_domain_id": int(staged.env["ROS_DOMAIN_ID"]),
        "foreign_publishers": end.foreign,
        "plant_node": end.bringup.plant_nodes[0] if end.bringup.plant_nodes else None,
        "plant_nodes": end.bringup.plant_nodes,
        "plant_adopted": end.bringup.adopted,
    }


def summarize_run(
    req: RunRequest, inputs: CheckedInputs, staged: StagedRun, end: RunEnd
) -> dict[str, Any] | None:
    """The run's summary rebuilt from its bag; None without a usable bag (an unusable
    one named in ``end.failure``). Tells a finished planner from the scenario's end."""
    from attitude_tools.bag.run_record import run_from_bag, summarize_bag  # see _preload

    bag = staged.tmp / "bag"
    if not (bag / "metadata.yaml").exists():
        return None
    recovered = end.recovery is not None and end.recovery.recovered
    try:
        if end.rebuilt is not None and not recovered:  # the bag the recorder closed
            bag_run = end.rebuilt.result()
            bag_run.run.wall_time_s = end.wall_s
        else:
            bag_run = run_from_bag(str(bag), inputs.scenario, wall_time_s=end.wall_s)
    except (ValueError, OSError) as err:
        end.failure = end.failure or f"bag unusable: {err}"
        return None
    if end.end_reason == "recording complete":
        codes_seen = set(bag_run.run.planner_status.tolist())
        ended = any(s.code in codes_seen for s in PlannerStatus.ending())
        end.end_reason = "planner finished" if ended else "scenario time ended"
    safe = next((f for f in bag_run.run.faults if f.kind is FaultKind.SAFE_MODE), None)
    if safe is not None:  # the state was lost for good: a failure naming it
        end.end_reason = "safe mode"
        end.failure = end.failure or (
            f"safe mode at {safe.t_start_s:.3f} s: the measured state ({ATTITUDE}, "
            f"{ANGULAR_VELOCITY}) was lost: {safe.detail}"
        )
    summary = summarize_bag(bag_run)
    summary.update(_run_summary_fields(req, staged, end))
    summary.update(run_fields(end.recovery, str(bag), bag_run.run.t))
    return summary


def no_bag_summary(
    req: RunRequest, inputs: CheckedInputs, staged: StagedRun, end: RunEnd
) -> dict[str, Any]:
    """``summary.json`` of a run without a usable bag: no step recorded, the failure named."""
    return {
        "scenario": inputs.scenario.name,
        "reached": False,
        "min_margin_deg": None,
        "steps_recorded": 0,
        **_run_summary_fields(req, staged, end),
        "failure": f"{end.failure or end.end_reason}; no usable bag",
    }


def write_summary(tmp: Path, summary: dict[str, Any]) -> None:
    """Write ``summary.json`` in the staging directory."""
    with open(tmp / "summary.json", "w") as f:
        dump_strict(summary, f, indent=2)  # NaN/inf -> null, named in non_finite


# -- 6. publish the run directory --------------------------------------------------------


def publish_run(
    nodes: NodeGraph, staged: StagedRun, out: Path, end: RunEnd, summary: dict[str, Any] | None
) -> dict[str, Any]:
    """Replace ``out`` with the staging directory (also after a failure: what was
    recorded is kept); then NodeInputError if a node refused its input, RunError
    without a summary. Returns the summary."""
    refused = [  # nodes that refused their input (a check attitude-run could not make)
        f"{n} exited with code 2: {nodes.error_line(n)}"
        for n, c in end.codes.items()
        if c == NODE_EXIT_BAD_INPUT
    ]
    publish(staged.tmp, out)  # also after a failure: what was recorded is kept
    if refused:
        raise NodeInputError("; ".join(refused) + f" (logs in {out / 'logs'})")
    if summary is None:
        raise RunError(f"{end.failure or end.end_reason}; no usable bag (logs in {out / 'logs'})")
    return summary
