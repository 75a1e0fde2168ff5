"""A run's record and its figures, from any source (offline loop, bag, campaign).

* ``trajectory``: ``RunResult``, the sampled closed-loop trajectory.
* ``metrics``: the dense body margin, the arrival time, path lengths.
* ``summary``: ``Summary``, the fields of ``summary.json`` (defined once), and
  ``summarize``.
"""
