"""Helpers shared by the test folders (core/, tools/, ros/): the repository root, the
workspace mark, exact-bits comparison, the two kernel forms, and ``attitude-run`` on a
reserved ROS 2 domain.

Imported as ``from support import ...``: ``tests/`` is on ``sys.path`` because pytest
(default ``prepend`` import mode) inserts the directory of ``tests/conftest.py``, which
is not in a package. The fixtures are in ``tests/conftest.py`` (every folder) and
``tests/ros/conftest.py`` (ROS 2 tests only).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any, ClassVar

import pytest
from hypothesis import HealthCheck

from attitude_tools.run.domain import DomainReservation, NoFreeDomain
from attitude_tools.run.domain import reserve_domain as _reserve_domain

ROOT = Path(__file__).resolve().parents[1]
needs_workspace = pytest.mark.skipif(
    not (ROOT / "ros2_ws" / "install" / "setup.bash").exists(),
    reason="colcon workspace not built (bash tools/bootstrap builds it)",
)
"""Mark for tests that start the project's nodes: they need the built colcon workspace."""


def exact_bits(value: Any) -> Any:
    """A value's exact identity, for comparing two computations to the bit: floats and
    float arrays by their bytes (NaN and signed zeros too), tuples element by element,
    anything else as it is."""
    import numpy as np

    if isinstance(value, (float, np.ndarray)):
        return np.asarray(value, dtype=float).tobytes()
    if isinstance(value, tuple):
        return tuple(exact_bits(v) for v in value)
    return value


KERNEL_MODES = ("compiled", "python")
"""The two forms of the per-step kernels (``attitude_core.kernels``): the compiled one and
the Python references."""


def kernel_functions(mode: str) -> SimpleNamespace:
    """The free per-step functions of one kernel form under the compiled module's names
    (``angle_between``, ``relative``, ``pd_command``): the compiled module's own, or the
    Python references (``mrp.*_single_reference``, ``pd.pd_command_reference``)."""
    from attitude_core import kernels
    from attitude_core.fsw.control.pd import pd_command_reference
    from attitude_core.models import mrp

    if mode == "compiled":
        module = kernels.built()
        assert module is not None, "the compiled kernels are not built (run tools/bootstrap)"
        return SimpleNamespace(
            angle_between=module.angle_between,
            relative=module.relative,
            pd_command=module.pd_command,
        )
    return SimpleNamespace(
        angle_between=mrp.angle_between_single_reference,
        relative=mrp.relative_single_reference,
        pd_command=pd_command_reference,
    )


MODE_SETTINGS: dict[str, Any] = {
    "deadline": None,
    # The same property test runs as a method of each form's class (its executor): by
    # design, as the examples that fail one form must be tried on the other.
    "suppress_health_check": [HealthCheck.differing_executors],
}
"""Hypothesis settings of a property test in a :class:`KernelModeTests` class."""


class KernelModeTests:
    """Base of the test classes that run once per kernel form, as CPython's tests of
    ``heapq`` run once with ``_heapq`` and once without: a subclass sets :attr:`mode` to
    ``"compiled"`` or ``"python"``, and every test of it runs with that form selected
    (``attitude_core.kernels.selected``: what a test makes keeps it). :attr:`K` holds the
    form's free functions (:func:`kernel_functions`). The compiled class is skipped when
    the kernels are not built."""

    mode: ClassVar[str]

    @pytest.fixture(autouse=True, scope="class")
    @classmethod
    def _kernel_mode(cls) -> Iterator[None]:
        from attitude_core import kernels

        mode = cls.mode
        if mode == "compiled" and kernels.built() is None:
            pytest.skip("the compiled kernels are not built (run tools/bootstrap)")
        with kernels.selected(mode):
            yield

    @property
    def K(self) -> SimpleNamespace:
        return kernel_functions(self.mode)


def run_env(domain: int) -> dict[str, str]:
    """The caller's environment on ROS domain ``domain``, discovery on this host only, for
    ``attitude-run`` (which finds the workspace itself)."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("AMENT_PREFIX_PATH", None)  # attitude-run finds the workspace itself
    return env


ATTITUDE_RUN = str(Path(sys.prefix) / "bin" / "attitude-run")


def _attitude_run_args(scenario: Path | str, out: Path | str, extra: tuple[str, ...]) -> list[str]:
    return [ATTITUDE_RUN, str(scenario), "--out", str(out), "--quiet", *extra]


def attitude_run(
    scenario: Path | str, out: Path | str, domain: int, *extra: str, timeout: float = 180
) -> subprocess.CompletedProcess[str]:
    """``attitude-run SCENARIO --out OUT --quiet EXTRA...`` on ROS domain ``domain``."""
    return subprocess.run(
        _attitude_run_args(scenario, out, extra),
        env=run_env(domain),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def spawn_attitude_run(
    scenario: Path | str, out: Path | str, env: dict[str, str], *extra: str, **popen: Any
) -> subprocess.Popen[str]:
    """The same, started in the background with ``env`` (:func:`run_env` for a domain of
    its own); stdout and stderr are piped, as text."""
    return subprocess.Popen(
        _attitude_run_args(scenario, out, extra),
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,
    )


def reserve_domain() -> DomainReservation:
    """Reserve a free ROS domain ID (:func:`attitude_tools.run.domain.reserve_domain`); fail
    the test if none is free."""
    try:
        return _reserve_domain()
    except NoFreeDomain as err:
        pytest.fail(str(err), pytrace=False)
