"""The main loop shared by every node: spin until done or shut down, exit cleanly.

``rclpy.experimental.EventsExecutor`` is several times faster across processes than
the default executor, but its ``spin()`` does not return on SIGINT/SIGTERM; the loop
therefore spins once at a time. SIGINT and SIGTERM only set a flag that the loop
checks (rclpy's own handlers would tear the context down under a running callback);
the node is then closed (a recorder finishes its bag) and rclpy shut down in order.

A node started by ``attitude-run`` also stops when attitude-run dies: the kernel sends
it SIGTERM (``attitude_tools.run.processes``), and, as a second line (e.g. with a real
``ros2 run`` in between, or off Linux), a parent watchdog here checks every
:data:`OWNER_CHECK_S` that the process named in
:data:`~attitude_core.runtime.process_identity.OWNER_ENV` is still alive.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from collections.abc import Callable
from typing import Any, NoReturn

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import ok as rclpy_ok  # rclpy.ok, where it is defined

from attitude_core.config.parameters import ParameterError
from attitude_core.config.scenario import ScenarioError
from attitude_core.contract.exit_codes import EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_OK  # noqa: F401
from attitude_core.runtime.process_identity import OWNER_ENV, ProcessIdentity
from attitude_ros import dds_profile

OWNER_CHECK_S = 0.5


class OwnerWatchdog:
    """Asks every :data:`OWNER_CHECK_S` whether the process in ``OWNER_ENV`` is alive."""

    def __init__(self) -> None:
        text = os.environ.get(OWNER_ENV, "")
        try:
            self.owner = ProcessIdentity.decode(text) if text else None
        except ValueError:
            print(f"warning: {OWNER_ENV}={text!r} ignored", file=sys.stderr, flush=True)
            self.owner = None
        self.next_check = time.monotonic() + OWNER_CHECK_S

    def owner_gone(self) -> bool:
        if self.owner is None or time.monotonic() < self.next_check:
            return False
        self.next_check = time.monotonic() + OWNER_CHECK_S
        if self.owner.alive():
            return False
        print(
            f"[{os.path.basename(sys.argv[0])}] the process that started this node "
            f"(pid {self.owner.pid}) is gone: shutting down",
            file=sys.stderr,
            flush=True,
        )
        return True


def run(
    node_factory: Callable[[], Node], args: list[str] | None = None, *, fast_exit: bool = False
) -> int:
    """Create the node with ``node_factory()``, spin it, and return the exit code.

    The node may set ``node.done = True`` to end the loop (end of a scenario) and
    ``node.exit_code``; it may define ``close()``, which runs on every way out
    (normal end, SIGINT, SIGTERM, exception), e.g. to finish a recording, and
    ``drained()``, polled after SIGINT/SIGTERM while queued messages are still taken.

    ``fast_exit`` (a node's executable): once the node is closed and destroyed (its
    peers see it leave the graph at once) and ROS 2 is shut down, the process ends with
    :func:`exit_process` instead of returning: no interpreter teardown, a fifth of a
    second less for each node at the end of every run.
    """
    code = _run(node_factory, args, restore_signals=not fast_exit)
    if fast_exit:
        exit_process(code)
    return code


def exit_process(code: int) -> NoReturn:
    """End this process now with ``code``: ROS 2 shut down and the default context
    destroyed, stdout and stderr flushed, then ``os._exit`` (Python's teardown of its
    modules skipped; nothing of ours is left to flush: a node's files are closed by its
    ``close``). Destroy the nodes first: their destruction is what removes them from
    the peers' graph; without it they stay listed until the participant's lease (10 s)
    runs out.

    The DDS participant must be destroyed before ``os._exit``: a process that ends with
    its participant alive can end while one of its Fast DDS threads holds the lock of a
    shared-memory port, and every peer that writes to that port then waits a second per
    write (seen as 1-3 s tails at the end of a run). The context's destruction waits
    for its last user, and reference cycles of the node's objects keep some alive, so
    they are collected first (20-40 ms). From here on SIGINT and SIGTERM are ignored: a
    second parent-death signal (one per exiting thread of the parent) must not end the
    process in the middle of this teardown. A segment still owned after all that is
    removed (:func:`attitude_core.runtime.shm_segments.remove_own_segments`)."""
    import gc

    import rclpy

    from attitude_core.runtime.shm_segments import remove_own_segments

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    rclpy.try_shutdown()
    gc.collect()  # the cycles holding the context's last users
    context = rclpy.get_default_context()
    if context.handle is not None:
        context.destroy()
    remove_own_segments()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing to save
            stream.flush()
    os._exit(code)


def _run(
    node_factory: Callable[[], Node], args: list[str] | None, restore_signals: bool = True
) -> int:
    stop = []
    previous = {
        s: signal.signal(s, lambda signum, frame: stop.append(signum))
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    dds_profile.apply()  # before rclpy.init: the stack's discovery timing
    try:
        rclpy.init(
            args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO
        )
    except RCLError as err:  # rcl refuses the command line, e.g. an unparsable params file
        program = os.path.basename(sys.argv[0]) if sys.argv else "node"
        print(f"[{program}] error: {err}", file=sys.stderr, flush=True)
        for s, handler in previous.items():
            signal.signal(s, handler)
        return EXIT_BAD_INPUT
    node = None
    executor: Any = None
    code = EXIT_OK
    try:
        node = node_factory()
        from rclpy.experimental.events_executor import EventsExecutor

        executor = EventsExecutor()
        executor.add_node(node)
        watchdog = OwnerWatchdog()
        while not stop and rclpy_ok() and not getattr(node, "done", False):
            try:
                executor.spin_once(timeout_sec=0.1)
            except (KeyboardInterrupt, ExternalShutdownException):
                raise
            except Exception as exc:  # a callback failed: ErrorProcessing, reported
                fail = getattr(node, "fail", None)
                if fail is None:
                    raise
                fail(exc)
            if watchdog.owner_gone():
                stop.append(signal.SIGTERM)
        drained = getattr(node, "drained", None)
        shut_down = getattr(node, "shutdown_requested", False)  # the lifecycle's shutdown
        if (stop or shut_down) and drained is not None:  # what is queued, for up to 1.5 s
            deadline = time.monotonic() + 1.5
            while rclpy_ok() and time.monotonic() < deadline and not drained():
                executor.spin_once(timeout_sec=0.05)
        code = getattr(node, "exit_code", EXIT_OK)
    except ParameterError as err:  # a scenario key or a node-own parameter
        if not getattr(err, "reported", False):  # a failed configure has named it
            name = "node" if node is None else node.get_name()
            what = "scenario" if isinstance(err, ScenarioError) else "parameter"
            print(f"[{name}] error: {what}: {err}", file=sys.stderr, flush=True)
        code = EXIT_BAD_INPUT
    except (KeyboardInterrupt, ExternalShutdownException):
        code = getattr(node, "exit_code", EXIT_OK)
    finally:
        if node is not None:  # a managed node releases only what it configured
            close = getattr(node, "release", None) or getattr(node, "close", None)
            if close is not None:
                close()
                if code == EXIT_OK:  # closing can fail too (a bag finished on a full disk)
                    code = getattr(node, "exit_code", EXIT_OK)
            if executor is not None:  # before the node goes: it holds the node's entities
                executor.shutdown()
            node.destroy_node()  # type: ignore[no-untyped-call]  # unannotated in rclpy
        if rclpy_ok():
            rclpy.shutdown()
        for s, handler in previous.items() if restore_signals else ():
            signal.signal(s, handler)  # else a late signal is only noted (the exit is near)
    return code
