"""What every node of the stack is: a managed (lifecycle) node of the node table, and
what it offers the main loop (:func:`attitude_ros.runner.run`).

The transitions are ROS 2's (``lifecycle_msgs``, as nav2 and ros2_control use them):

* ``configure``: the node's :meth:`StackNode.configure` (parameters read and validated,
  scenario loaded, tables and route built, publishers and subscriptions created). A
  refused parameter or scenario fails the transition with the named error; the
  process then exits 2 (``EXIT_BAD_INPUT``).
* ``activate``: the loop starts (:attr:`StackNode.active`; the node's :meth:`activate`).
  Inputs that arrive while inactive are not acted on.
* ``deactivate``: a safe stop (the node's :meth:`deactivate`: zero torque, a held
  target, no stepping, a flushed bag); ``activate`` resumes.
* ``cleanup`` / ``shutdown``: everything released (:meth:`close`); after ``shutdown``
  the process exits with the node's exit code.
* An exception in a transition or a callback goes to ``ErrorProcessing`` (a callback's
  through ``shutdown``): the node logs it, the state machine reports it on
  ``~/transition_event``, and it ends in ``finalized``, exit 1.

``-p autostart:=true`` configures and activates the node at construction (nav2's
convention); without it the node comes up ``unconfigured`` and waits for a manager
(``attitude-run``, ``ros2 lifecycle set``, a launch file's lifecycle events).
"""

from __future__ import annotations

import sys
import traceback
from typing import Any, ClassVar, Protocol

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn

from attitude_core.config import node_parameters
from attitude_core.config.node_graph import NodeSpec
from attitude_core.config.parameters import ParameterError
from attitude_core.config.scenario import ScenarioError
from attitude_core.contract.exit_codes import EXIT_BAD_INPUT, EXIT_FAILURE
from attitude_ros.params import declare_rows

__all__ = ["StackNode", "Stoppable"]

_OK, _FAILED = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE


class Stoppable(Protocol):
    """The main loop's view of a node."""

    done: bool
    exit_code: int

    def close(self) -> None: ...


class StackNode(LifecycleNode):
    """A managed node of the node table (``spec``, a class attribute), named as the
    table says. Subclasses implement :meth:`configure` (and, where they act on a
    transition, :meth:`activate` and :meth:`deactivate`)."""

    spec: ClassVar[NodeSpec[Any]]

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(self.spec.node_name, **kwargs)
        self.done, self.exit_code = False, 0
        self.active = False
        self.configured = False
        self.shutdown_requested = False
        self.error: str | None = None  # what sent the node to ErrorProcessing
        self.input_error: ParameterError | None = None  # a refused parameter or scenario
        common = declare_rows(self, node_parameters.LIFECYCLE)
        if common.autostart:
            self.trigger_configure()  # type: ignore[no-untyped-call]  # unannotated
            if self.input_error is not None:
                raise self.input_error  # the runner names it and exits 2, as by hand
            if self.configured:
                self.trigger_activate()  # type: ignore[no-untyped-call]

    # -- what a node implements ------------------------------------------------------

    def configure(self) -> None:
        """Read parameters, build the node's core objects and endpoints (raise
        :class:`ParameterError` on a refused input)."""
        raise NotImplementedError

    def activate(self) -> None:
        """Start acting (after :attr:`active` is set)."""

    def deactivate(self) -> None:
        """Stop acting safely (after :attr:`active` is cleared)."""

    @property
    def takes_input(self) -> bool:
        """Whether inputs are acted on now (active; a node that answers while inactive,
        the planner holding its target, says so)."""
        return self.active

    @property
    def rejected(self) -> int:
        """Input messages refused so far, for their stamp or their content."""
        return 0

    def log(self) -> Any:
        """The node's logger (rclpy's ``get_logger`` is unannotated)."""
        return self.get_logger()  # type: ignore[no-untyped-call]

    def plant_nodes(self) -> tuple[str, ...]:
        """The nodes adopted as the plant (``plant_nodes``; empty: none named)."""
        value = self.get_parameter("plant_nodes").value or []
        return tuple(name for name in value if name)

    def stop(self, code: int, reason: str = "") -> None:
        """The run guard's verdict: stop answering, end the main loop with ``code``."""
        self.done, self.exit_code = True, code
        self.active = False

    def close(self) -> None:
        """Release what the node holds (threads, files); runs on every way out."""

    # -- the transitions -----------------------------------------------------------------

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            self.configure()
        except ParameterError as err:
            what = "scenario" if isinstance(err, ScenarioError) else "parameter"
            print(f"[{self.get_name()}] error: {what}: {err}", file=sys.stderr, flush=True)
            err.reported = True  # type: ignore[attr-defined]  # the runner does not repeat it
            self.input_error = err
            self.done, self.exit_code = True, EXIT_BAD_INPUT
            return _FAILED
        except Exception as exc:  # noqa: BLE001  # reported, then ErrorProcessing
            return self._raised(exc)
        self.configured = True
        return _OK

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = True
        try:
            self.activate()
        except Exception as exc:  # noqa: BLE001
            return self._raised(exc)
        self.log().info("active")
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        try:
            self.deactivate()
        except Exception as exc:  # noqa: BLE001
            return self._raised(exc)
        self.log().info("inactive: safe stop")
        return super().on_deactivate(state)

    def _raised(self, exc: BaseException) -> TransitionCallbackReturn:
        """A transition's own code raised: log it; the transition errs (ErrorProcessing)."""
        self.active = False
        self.error = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        self.log().error("".join(traceback.format_exception(exc)).rstrip())
        return TransitionCallbackReturn.ERROR

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.release()
        return _OK

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        if self.error is not None:  # a callback failed: on to ErrorProcessing
            return TransitionCallbackReturn.ERROR
        # The main loop ends; it drains what is queued (a recorder) and then releases.
        self.done = self.shutdown_requested = True
        return _OK

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        reason = self.error or f"a transition from {state.label} raised"
        self.log().error(f"error processing: {reason}")
        self.active, self.done = False, True
        self.exit_code = self.exit_code or EXIT_FAILURE
        self.release()
        return _FAILED  # ErrorProcessing -> finalized

    def fail(self, exc: BaseException) -> None:
        """An exception escaped a callback: report it and go to ErrorProcessing."""
        self._raised(exc)
        # ShuttingDown errs (on_shutdown sees the error): on to ErrorProcessing.
        self.trigger_shutdown()  # type: ignore[no-untyped-call]

    def release(self) -> None:
        """Close, then destroy what :meth:`configure` created (the lifecycle and
        parameter interfaces stay)."""
        if not self.configured:
            return
        self.configured = False
        self.close()
        for timer in list(self.timers):
            self.destroy_timer(timer)
        for sub in list(self.subscriptions):
            self.destroy_subscription(sub)
        keep = self._parameter_event_publisher
        for pub in [p for p in self.publishers if p is not keep]:
            self.destroy_publisher(pub)
