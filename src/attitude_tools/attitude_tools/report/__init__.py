"""Run reports from recorded bags: ``attitude-report DIR [DIR_B --out OUT]``.

One module per job: ``data`` (a run rebuilt from its bag and its summary figures),
``geometry`` (sky circles, boresight paths and MRP-space keep-out surfaces, plain
NumPy and scikit-image), ``sky`` (the plotted margins, against the sky of each
instant, and moving objects' tracks and cones), ``figures`` (the PNG figures,
matplotlib Agg), ``html`` (the self-contained ``report.html``) and ``cli`` (the
command, atomic output).
"""
