"""Shared fixtures: a reserved ROS 2 domain per test (or per module fixture).

Tests that start ROS 2 nodes must not share a DDS domain with each other, with a
concurrent test run on the same machine, or with anything else using the
``domain_coordinator`` convention of ROS 2: each test holds the lock of
:mod:`attitude_tools.run.domain` (the one ``attitude-run`` takes when no ``ROS_DOMAIN_ID`` is
set) on a domain of its own, freed by the kernel however the test process ends.

These fixtures are used by every folder (core/, tools/ and ros/ have tests that run
``attitude-run`` or the nodes); the helpers they share are in ``support.py``, the
fixtures of the ROS 2 tests alone in ``ros/conftest.py``.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from support import reserve_domain

from attitude_tools.run.domain import domain_environment

# The helper modules next to the tests assert like the tests do: rewritten by pytest, so a
# failing helper shows its values (registered before a test module imports them).
pytest.register_assert_rewrite(
    "bag_checks", "parameter_rows", "ros_helpers", "scenario_params", "shells"
)


@pytest.fixture(scope="session")
def reserve_ros_domain():
    """The reservation function, for module- or session-scoped fixtures::

    with reserve_ros_domain() as domain:   # domain.id, domain.env()
        ...
    """
    return reserve_domain


@pytest.fixture
def ros_domain() -> Iterator[int]:
    """A ROS domain ID reserved for this test only (released after its teardown)."""
    with reserve_domain() as domain:
        yield domain.id


@pytest.fixture
def ros_env(ros_domain):
    """``ros_env(base=None)``: a copy of ``base`` (default ``os.environ``) set to the test's
    reserved domain, localhost discovery only."""
    return lambda base=None: domain_environment(ros_domain, base)
