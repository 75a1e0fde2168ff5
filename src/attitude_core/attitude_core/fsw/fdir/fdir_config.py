"""The ``fdir.*`` limits of the state watchdog (a leaf: no other import of the package).

Ages are measured on the stack's clock from the newest measured state's stamp, in
integer nanoseconds, so the simulator (which paces lockstep ticks by the same rule) and
the flight software decide alike to the last bit.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FdirConfig", "DEFAULT_TIMEOUT_STEPS", "BRAKED_RATE_RAD_S", "NS_PER_S"]

NS_PER_S = 1_000_000_000
DEFAULT_TIMEOUT_STEPS = 3
"""``fdir.state_timeout_s`` when not declared: this many loop steps."""
BRAKED_RATE_RAD_S = 1.0e-5
"""Braking ends, and zero torque is commanded, when the predicted rate is below this."""


@dataclass(frozen=True)
class FdirConfig:
    """``state_timeout_s``: a state older than this is stale and the loop flies on a
    prediction; ``predict_s``: without a state for this long, brake the predicted rate
    to zero, then command zero torque; ``safe_after_s``: safe mode (zero torque, the run
    ends). Ages in seconds since the newest state's stamp."""

    state_timeout_s: float
    predict_s: float = 3.0
    safe_after_s: float = 10.0

    def __post_init__(self) -> None:
        if not 0.0 < self.state_timeout_s < self.predict_s < self.safe_after_s:
            raise ValueError(
                "fdir: need 0 < state_timeout_s < predict_s < safe_after_s, got "
                f"{self.state_timeout_s}, {self.predict_s}, {self.safe_after_s}"
            )

    @classmethod
    def for_step(cls, dt_s: float) -> FdirConfig:
        """The defaults for a loop step of ``dt_s`` seconds."""
        return cls(DEFAULT_TIMEOUT_STEPS * dt_s)

    @property
    def timeout_ns(self) -> int:
        return round(self.state_timeout_s * NS_PER_S)

    @property
    def predict_ns(self) -> int:
        return round(self.predict_s * NS_PER_S)

    @property
    def safe_ns(self) -> int:
        return round(self.safe_after_s * NS_PER_S)

    def stale(self, age_ns: int) -> bool:
        """A state ``age_ns`` old is stale: the loop no longer flies on it."""
        return age_ns > self.timeout_ns
