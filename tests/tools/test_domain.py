"""Domain reservations (``attitude_tools.run.domain``): the lock, and the cool-down of
a released ID (a run's nodes may still be stopping when its holder releases it)."""

import os
import socket
import time

import pytest

from attitude_tools.run import domain


@pytest.fixture
def ids(monkeypatch, tmp_path):
    """Reservations on their own stamp directory, over IDs ``ids(range)``."""
    monkeypatch.setattr(domain, "cooldown_dir", lambda: str(tmp_path))

    def over(span: range) -> None:
        monkeypatch.setattr(domain, "DOMAIN_IDS", span)

    return over


def _take_all() -> list[domain.DomainReservation]:
    held = []
    try:
        while True:
            held.append(domain.reserve_domain())
    except domain.NoFreeDomain:
        return held


def test_a_reserved_id_is_locked_until_released(ids):
    ids(range(70, 74))
    with domain.reserve_domain() as first:
        probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        with pytest.raises(OSError):
            probe.bind(("127.0.0.1", domain.DOMAIN_PORT_BASE + first.id))
        probe.close()
        others = _take_all()
        assert first.id not in [h.id for h in others]
        for h in others:
            h.release()
    first.release()  # idempotent
    with domain.reserve_domain() as again:  # free again (last, but free)
        assert again.id in range(70, 74)


def test_a_released_id_is_handed_out_again_last_while_it_cools_down(ids):
    ids(range(74, 79))
    first = domain.reserve_domain()
    released = first.id
    first.release()
    held = _take_all()
    try:
        taken = [h.id for h in held]
        assert released in taken
        assert taken[-1] == released  # only once every other free ID was taken
    finally:
        for h in held:
            h.release()


def test_the_cool_down_ends(ids):
    ids(range(79, 81))
    a = domain.reserve_domain()
    b = domain.reserve_domain()
    a_id, b_id = a.id, b.id
    a.release()
    b.release()  # both cooling: b the more recent
    past = time.time() - domain.COOLDOWN_S - 1.0
    os.utime(os.path.join(domain.cooldown_dir(), str(a_id)), (past, past))
    with domain.reserve_domain() as next_one:
        assert next_one.id == a_id  # cooled down: before the one still cooling
    assert b_id != a_id
