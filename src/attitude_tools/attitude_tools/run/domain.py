"""ROS domain IDs reserved with a lock, as ROS 2's ``domain_coordinator`` does.

A domain ``d`` is in use while some process holds a TCP socket bound to port
``DOMAIN_PORT_BASE + d`` on this host. We take ``domain_coordinator``'s base port, so our
reservations and its exclude each other. The socket is only bound (never listened on,
so nothing can connect to it), it is not inherited by child processes (Python's
default), and the kernel frees it when the holder ends, however it ends: a crashed run
leaves no stale reservation.

IDs are 1..101 only: on Linux the DDS ports of domain ``d`` (7400 + 250 d + ...) stay
below the ephemeral port range (32768...) for those, and 0, the default domain, is left
to interactive use. The IDs are tried in random order; ``bind`` is atomic, so two
processes can never hold the same one, and a taken port is simply skipped.

A released ID cools down for :data:`COOLDOWN_S` before it is handed out again (unless
every other ID is taken): the processes of the run or test that held it may still be
stopping (a node's bring-down can take seconds on a loaded machine, an orphan notices
its dead parent within a poll), and their nodes must not show up in the next holder's
graph. :meth:`DomainReservation.release` stamps the ID's file in
:func:`cooldown_dir`; the stamps are a preference, never a lock (a holder that dies
without releasing leaves none, and its ID is free at once, as before).

``attitude-run`` reserves one for the run when the caller set no ``ROS_DOMAIN_ID``; the
tests reserve one per test.
"""

from __future__ import annotations

import os
import random
import socket
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

from attitude_core.runtime import discovery

__all__ = [
    "COOLDOWN_S",
    "DOMAIN_PORT_BASE",
    "DOMAIN_IDS",
    "NoFreeDomain",
    "DomainReservation",
    "domain_environment",
    "reserve_domain",
]

DOMAIN_PORT_BASE = 22119  # domain_coordinator's _PORT_BASE
DOMAIN_IDS = range(1, 102)
COOLDOWN_S = 30.0
"""A released domain ID is handed out again only after this (s), while others are free."""


def cooldown_dir() -> str:
    """Where released IDs are stamped: ``attitude_domains-<uid>`` in the temp directory."""
    return os.path.join(tempfile.gettempdir(), f"attitude_domains-{os.getuid()}")


def _released_at(domain_id: int) -> float:
    """When ``domain_id`` was last released (epoch s), or -inf when it has no stamp."""
    try:
        return os.stat(os.path.join(cooldown_dir(), str(domain_id))).st_mtime
    except OSError:
        return -float("inf")


def _stamp_release(domain_id: int) -> None:
    """Stamp ``domain_id`` as released now (best effort: a failure only loses its cool-down)."""
    try:
        os.makedirs(cooldown_dir(), mode=0o700, exist_ok=True)
        Path(cooldown_dir(), str(domain_id)).touch()
    except OSError:
        pass


class NoFreeDomain(RuntimeError):
    pass


class DomainReservation:
    """A reserved ROS domain ID: held until :meth:`release` (or the ``with`` block ends)."""

    def __init__(self, domain_id: int, sock: socket.socket) -> None:
        self.id = domain_id
        self._sock = sock

    def env(self, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """A copy of ``base`` (default ``os.environ``) for this domain, discovery on this
        host only."""
        return domain_environment(self.id, base)

    def release(self) -> None:
        """Free the ID (it then cools down for :data:`COOLDOWN_S`); idempotent."""
        if self._sock.fileno() == -1:
            return
        _stamp_release(self.id)
        self._sock.close()

    def __enter__(self) -> DomainReservation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def domain_environment(domain_id: int, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default ``os.environ``) on ``domain_id``, discovery on this host only (no
    static peers, no deprecated ``ROS_LOCALHOST_ONLY``)."""
    env = dict(os.environ if base is None else base)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_STATIC_PEERS", None)
    env.pop("ROS_LOCALHOST_ONLY", None)
    return env


def reserve_domain() -> DomainReservation:
    """Reserve a free ROS domain ID in 1..101 (random order, those released within
    :data:`COOLDOWN_S` last); NoFreeDomain if none is."""
    ids = list(DOMAIN_IDS)
    random.SystemRandom().shuffle(ids)
    now = time.time()
    ids.sort(key=lambda d: now - _released_at(d) < COOLDOWN_S)  # stable: cooling ones last
    for domain_id in ids:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            sock.bind(("127.0.0.1", DOMAIN_PORT_BASE + domain_id))
        except OSError:
            sock.close()
            continue
        return DomainReservation(domain_id, sock)
    raise NoFreeDomain(
        f"no free ROS domain ID: all of {DOMAIN_IDS.start}..{DOMAIN_IDS.stop - 1} are "
        f"reserved (TCP ports {DOMAIN_PORT_BASE + DOMAIN_IDS.start}.."
        f"{DOMAIN_PORT_BASE + DOMAIN_IDS.stop - 1} on 127.0.0.1 are bound): too many "
        "concurrent ROS runs, or leftover processes holding them (see `ss -tanp`)"
    )


PROBE_WAIT_S = discovery.PROBE_WAIT_S
"""Discovery time the busy-domain probe allows, s. Localhost discovery usually takes
0.1 s, but a participant that misses the probe's first announcements is only found at
its next periodic one: the stack's nodes announce every 0.5 s (Fast DDS's default is
3 s; measured then: some nodes of a live run found after 2.7-2.9 s)."""


class DomainBusyError(RuntimeError):
    """Nodes of another run are alive on the domain a run was to use."""


def alive_nodes(
    env: Mapping[str, str], python: str, wait_s: float = PROBE_WAIT_S
) -> list[list[str]]:
    """``[namespace, name]`` of every node on the domain of ``env`` (a probe process:
    ``python -m attitude_ros.domain_probe``, with the workspace on ``env``'s paths)."""
    import json
    import subprocess

    out = subprocess.run(
        [python, "-m", "attitude_ros.domain_probe", "--wait-s", str(wait_s)],
        env=dict(env),
        capture_output=True,
        text=True,
        timeout=60.0 + wait_s,
        check=False,
    )
    if out.returncode != 0:
        raise RuntimeError(f"domain probe failed (exit {out.returncode}): {out.stderr.strip()}")
    nodes: list[list[str]] = json.loads(out.stdout)
    return nodes


def claim_domain(env: dict[str, str], python: str) -> DomainReservation | None:
    """Pick the run's domain in ``env`` (in place) and check it is free of other runs.

    Without ``ROS_DOMAIN_ID``, a free domain is reserved (the caller releases the
    returned reservation at the end of the run) and not probed: every run and every
    test takes the same lock, so no other run can be there (a node started by hand on
    that ID, outside the lock, is still caught by the run guards, named as a foreign
    publisher). With ``ROS_DOMAIN_ID`` set, that domain is used as is, after a probe:
    DomainBusyError names the nodes of another run alive there.
    """
    from attitude_core.runtime.run_identity import Endpoint, foreign_run_nodes

    if not env.get("ROS_DOMAIN_ID", "").strip():
        reservation = reserve_domain()
        env["ROS_DOMAIN_ID"] = str(reservation.id)
        return reservation
    nodes = [Endpoint(ns, name) for ns, name in alive_nodes(env, python)]
    others = foreign_run_nodes(nodes, own_namespace=None)
    if others:
        names = ", ".join(e.node for e in others)
        raise DomainBusyError(
            f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}: nodes of another run are alive: {names}; "
            "stop them, or choose another ROS_DOMAIN_ID (unset it and attitude-run "
            "reserves a free one)"
        )
    return None
