# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""Compiled per-step kernels of the closed loop (C through Cython, built ahead of time).

One include per Python module it mirrors (each names its module and the paper's
equations in its header); the Python forms stay in those modules as the references the
tests compare against, run with ``ATTITUDE_KERNELS=python``:

* ``shared.pxi``: the constants and float helpers every kernel uses;
* ``mrp.pxi``: :mod:`attitude_core.models.mrp` (:func:`angle_between`, :func:`relative`);
* ``control.pxi``: :mod:`attitude_core.fsw.control.pd` and ``saturation``
  (:func:`pd_command`, eq. 11 scaled into the bound);
* ``rigid_body.pxi``: :mod:`attitude_core.world.rigid_body` (:func:`rk4_step`, eqs. 2-4);
* ``loop_plant.pxi``: :mod:`attitude_core.loop.loop_plant` (:class:`LoopPlant`);
* ``constraints.pxi``: :mod:`attitude_core.models.constraints` (:class:`ConeKernel`,
  eq. 5 and the MRP-space obstacles);
* ``metrics.pxi``: :mod:`attitude_core.record.metrics`'s dense margin
  (:func:`dense_interval_minima`);
* ``fis_table.pxi``: :mod:`attitude_core.fsw.guidance.fuzzy.table` (:class:`FisKernel`);
* ``fepf.pxi``: :mod:`attitude_core.fsw.guidance.fepf` and ``fepf_state``
  (:class:`FepfState`, :class:`FepfCore`, eqs. 6-10, 12);
* ``route_following.pxi``: :mod:`attitude_core.fsw.guidance.route_following`;
* ``guidance.pxi``: :mod:`attitude_core.fsw.guidance.guidance` and ``guidance_state``
  (:class:`GuidanceState`, :class:`GuidanceCore`).

Arithmetic is IEEE double without contraction (``-ffp-contract=off``), in the
references' order, with libm's functions as Python's ``math`` calls them (``pow`` too:
``-fno-builtin-pow`` keeps ``x ** 2`` a library call), so every kernel agrees with its
reference to the last bit, the whole closed loop too (``tests/core/test_kernels.py``).
The one exception is the dense-margin screen, which only chooses what its NumPy
reference measures (``metrics.pxi``).
"""

import numpy as np

include "shared.pxi"
include "mrp.pxi"
include "control.pxi"
include "rigid_body.pxi"
include "loop_plant.pxi"
include "constraints.pxi"
include "metrics.pxi"
include "fis_table.pxi"
include "fepf.pxi"
include "route_following.pxi"
include "guidance.pxi"
