"""Mamdani fuzzy inference systems (FIS) for the fuzzy enhanced potential field.

The planner commands the target MRP rate (paper eq. 6)

    sigma_t_dot = m_a * sigma_a_hat + m_r * sigma_r_hat,

where the magnitudes ``m_a`` (attraction) and ``m_r`` (repulsion) come from two FIS
whose outputs are normalised to [0, 1] and multiplied by a rate scale in MRP/s by the
planner. The FIS are data (``attitude_core/data/fis_*.yaml``, schema in
:mod:`.spec`), loaded by :mod:`.load`, evaluated exactly by :mod:`.mamdani` (terms:
:mod:`.membership`) and tabulated for the hot path by :mod:`.table` (knots:
:mod:`.refine`). See ``docs/fuzzy_design.md``.
"""

from attitude_core.fsw.guidance.fuzzy.files import packaged_fis_files
from attitude_core.fsw.guidance.fuzzy.load import load_fis
from attitude_core.fsw.guidance.fuzzy.mamdani import MamdaniFis
from attitude_core.fsw.guidance.fuzzy.membership import SHAPES as SHAPES
from attitude_core.fsw.guidance.fuzzy.membership import membership
from attitude_core.fsw.guidance.fuzzy.spec import FisError
from attitude_core.fsw.guidance.fuzzy.table import FisTable, lookup_table

__all__ = [
    "FisError",
    "MamdaniFis",
    "FisTable",
    "load_fis",
    "lookup_table",
    "membership",
    "packaged_fis_files",
]
