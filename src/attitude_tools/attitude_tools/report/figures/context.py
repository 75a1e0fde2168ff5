"""What every figure needs (in: the runs and the MRP grid size; out: their distinct
keep-out pairs and keep-in cones with colours, the MRP-space surfaces, computed once,
the 3D view and the title)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import Vec3, to_principal

from ..data import ReportRun
from ..geometry import KeepIn, Pair, best_view, keep_ins_of, mrp_surface, pairs_of
from .style import KEEP_IN_COLORS, PAIR_COLORS, RUN_COLORS

__all__ = ["Floats", "FigureContext"]

Floats = npt.NDArray[np.float64]


class FigureContext:
    """What every figure needs: the runs, their distinct cones, colours and names."""

    def __init__(self, runs: Sequence[ReportRun], mrp_grid: int) -> None:
        self.runs = runs
        self.pairs = pairs_of([r.scenario for r in runs])
        self.n_instruments = len({p.instrument_key for p in self.pairs})
        self.pair_color = {p: PAIR_COLORS[k % len(PAIR_COLORS)] for k, p in enumerate(self.pairs)}
        self.keep_ins = keep_ins_of([r.scenario for r in runs])
        self.keep_in_color = {
            c: KEEP_IN_COLORS[k % len(KEEP_IN_COLORS)] for k, c in enumerate(self.keep_ins)
        }
        self.mrp_grid = mrp_grid
        self._surfaces: list[tuple[Pair, Floats | None]] | None = None
        self._keep_in_surfaces: list[tuple[KeepIn, Floats | None]] | None = None
        pts = [to_principal(r.run.sigma_bn) for r in runs]
        pts += [
            to_principal(np.array([r.scenario.initial_mrp, r.scenario.desired_mrp])) for r in runs
        ]
        self.view = best_view(np.concatenate(pts))
        if len(runs) == 1:
            self.title = runs[0].label
        else:
            self.title = " vs ".join(r.label for r in runs)

    def run_color(self, k: int, default: str = "tab:blue") -> str:
        return RUN_COLORS[k] if len(self.runs) > 1 else default

    @property
    def compare(self) -> bool:
        return len(self.runs) > 1

    def surfaces(self) -> list[tuple[Pair, Floats | None]]:
        if self._surfaces is None:
            self._surfaces = [(p, mrp_surface(p, self.mrp_grid)) for p in self.pairs]
        return self._surfaces

    def keep_in_surfaces(self) -> list[tuple[KeepIn, Floats | None]]:
        if self._keep_in_surfaces is None:
            self._keep_in_surfaces = [(c, mrp_surface(c, self.mrp_grid)) for c in self.keep_ins]
        return self._keep_in_surfaces

    def instruments(self) -> list[tuple[str, Vec3, float | None]]:
        """Distinct instruments (name, boresight, half-angle or None), in order."""
        seen: list[tuple[str, Vec3, float | None]] = []
        for p in self.pairs:
            key = p.instrument_key
            if key not in seen:
                seen.append(key)
        return seen
