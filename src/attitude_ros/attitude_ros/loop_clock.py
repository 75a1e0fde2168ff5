"""The stack's clock for the state watchdog: ``/clock`` in lockstep, wall time otherwise.

A lockstep plant publishes ``/clock``; a real-time one does not. So the node listens to
``/clock`` on a reliable subscription of its own (rclpy's time source listens best
effort, depth 1, and only with ``use_sim_time``): once a ``/clock`` has come, the
loop's ticks are the ``/clock`` messages and a state's time is its stamp (the simulator
publishes each tick's ``/clock`` after the answer it waits for, so a lockstep run stays
deterministic, however slowly it steps). Until then the ticks come from a wall timer of
the loop's step and a state's time is its receipt on this host's clock, whatever clock
the plant stamps with. The first ``/clock`` calls ``on_rebase`` (a watchdog armed on
wall times starts again on stamps) and stops the wall timer.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.clock import Clock, ClockType

from attitude_ros import contract as c
from attitude_ros.convert import stamp_ns
from attitude_ros.endpoints import subscription

__all__ = ["LoopClock"]


class LoopClock:
    """See the module docstring. ``on_tick(now_ns)`` is called at each tick."""

    def __init__(
        self,
        node: Any,
        dt_s: float,
        on_tick: Callable[[int], None],
        on_rebase: Callable[[], None] | None = None,
    ) -> None:
        self.node = node
        self.on_tick = on_tick
        self.on_rebase = on_rebase
        self.clock_ns: int | None = None  # the newest /clock
        self.system = Clock(clock_type=ClockType.SYSTEM_TIME)
        self.sub = subscription(node, c.CLOCK, self._on_clock)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.timer = node.create_timer(dt_s, self._on_wall, clock=steady)

    @property
    def lockstep(self) -> bool:
        """Ticks and state times are sim time (a ``/clock`` has come)."""
        return self.clock_ns is not None

    def now_ns(self) -> int:
        """The stack's time now: the newest ``/clock``, else the node's wall clock."""
        if self.clock_ns is not None:
            return self.clock_ns
        return int(self.system.now().nanoseconds)

    def state_time_ns(self, stamp: int) -> int:
        """A state's time for the watchdog: its stamp in lockstep, else its receipt."""
        return stamp if self.clock_ns is not None else self.now_ns()

    def _on_clock(self, msg: Any) -> None:
        ns = stamp_ns(msg.clock)
        first = self.clock_ns is None
        if not first and ns < self.clock_ns:  # type: ignore[operator]
            return
        self.clock_ns = ns
        if first:
            self.timer.cancel()
            if self.on_rebase is not None:
                self.on_rebase()
        self.on_tick(ns)

    def _on_wall(self) -> None:
        if self.clock_ns is None:
            self.on_tick(self.now_ns())
