"""The manager's view of a managed node (``LifecycleClient``) against ``get_state``
servers that misbehave as real ones can, over real DDS on the test's own domain: one
that answers late (every answer after the next request was sent), one whose first
answer is lost. The servers run on their own node and executor in a thread."""

from __future__ import annotations

import contextlib
import threading
import time

import pytest
from lifecycle_msgs.srv import GetState
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from attitude_ros.lifecycle_client import STATE_RETRY_S, LifecycleClient

pytestmark = pytest.mark.ros

WAIT_S = 30.0


class StateServer:
    """``/managed/get_state`` answering ``label`` after ``delay_s``; the first
    ``drop`` requests get no answer (the callback returns None, which rclpy refuses to
    send: the request is taken and never answered)."""

    def __init__(self, delay_s: float = 0.0, drop: int = 0, label: str = "active") -> None:
        self.node = Node("managed")
        self.delay_s, self.drop, self.label = delay_s, drop, label
        self.requests = 0
        self.node.create_service(GetState, "/managed/get_state", self.answer)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.running = True
        self.thread = threading.Thread(target=self.spin, daemon=True)
        self.thread.start()

    def spin(self) -> None:
        while self.running:
            # rclpy refuses to send None (TypeError): the request is dropped
            with contextlib.suppress(TypeError):
                self.executor.spin_once(timeout_sec=0.02)

    def answer(self, request, response):
        self.requests += 1
        if self.requests <= self.drop:
            return None
        time.sleep(self.delay_s)  # busy: this server answers one request at a time
        response.current_state.label = self.label
        return response

    def close(self) -> None:
        self.running = False
        self.thread.join(5.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()


@pytest.fixture
def client(ros):
    ros.init()
    lc = LifecycleClient(ros.probe, "/managed", lambda *e: None, executor=ros.executor)
    return ros, lc


def _wait_ready(ros, lc) -> None:
    ros.spin_until(lc.get.service_is_ready, "the get_state service")


def test_a_server_slower_than_the_retry_period_is_still_heard(client):
    ros, lc = client
    server = StateServer(delay_s=2.5 * STATE_RETRY_S)
    try:
        _wait_ready(ros, lc)
        t0 = time.monotonic()
        assert lc.state(WAIT_S) == "active"
        # Requests were sent again while the first was answered (late answers count).
        assert server.requests >= 2
        assert time.monotonic() - t0 < WAIT_S / 2
    finally:
        server.close()


def test_a_lost_first_answer_is_asked_for_again(client):
    ros, lc = client
    server = StateServer(drop=1, label="inactive")
    try:
        _wait_ready(ros, lc)
        assert lc.state(WAIT_S) == "inactive"
        assert server.requests >= 2
    finally:
        server.close()


def test_no_answer_at_all_is_none_after_the_timeout_or_once_gone(client):
    ros, lc = client
    server = StateServer(drop=10**6)
    try:
        _wait_ready(ros, lc)
        t0 = time.monotonic()
        assert lc.state(0.5) is None
        assert time.monotonic() - t0 >= 0.5
        assert lc.state(WAIT_S, gone=lambda: server.requests >= 3) is None
        assert server.requests >= 3
    finally:
        server.close()
