"""A goal placed just outside a keep-out: what ``dispersions.goal_near_keep_out`` draws.

Inputs: a loaded scenario's sky, a goal ``sigma_DN``, a keep-out pair (an instrument and
an object it avoids), the wanted margin and the time it holds at. Output: the goal turned
by the smallest rotation that puts the instrument's boresight that margin outside the
object's keep-out (measured from the limb, eq. 5) at that time.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from attitude_core.models.mrp import Vec3Like, to_principal
from attitude_core.models.sky import Sky

__all__ = ["goal_at_margin", "keep_out_pairs"]


def keep_out_pairs(sky: Sky) -> int:
    """How many keep-out pairs the sky has (the first constraints of its margins)."""
    return len(sky.pair_instrument)


def goal_at_margin(
    sky: Sky, sigma_goal: Vec3Like, pair: int, margin_deg: float, t_s: float = 0.0
) -> npt.NDArray[np.float64]:
    """``sigma_goal`` turned about the axis normal to the boresight of keep-out ``pair``
    and its object's direction (inertial) so that the pair's margin at ``t_s`` is
    ``margin_deg`` (the principal MRP set). The boresight and the object must not be
    parallel."""
    i, j = int(sky.pair_instrument[pair]), int(sky.pair_object[pair])
    rotation = Rotation.from_mrp(np.array(sigma_goal, dtype=float))  # C_NB
    boresight_n = rotation.apply(np.array(sky.boresights_body[i]))
    dirs, _ = sky.object_directions(t_s)
    axis = np.cross(dirs[j], boresight_n)
    norm = float(np.linalg.norm(axis))
    if norm < 1e-9:
        raise ValueError(f"keep-out pair {pair}: the boresight is along the object")
    now = float(sky.constraint_margins_deg(t_s, np.asarray(sigma_goal, dtype=float))[pair])
    turn = Rotation.from_rotvec(axis / norm * math.radians(margin_deg - now))
    return to_principal((turn * rotation).as_mrp())
