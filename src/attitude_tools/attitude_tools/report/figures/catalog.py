"""Which figures a report has: file name -> (title, caption), in report order.

The paper's simulation section shows the keep-out cones in the inertial frame and as
regions in MRP space (its Fig. "Keep-Out Constraints"), the MRP trajectory among the
regions and the boresight trajectory on the right ascension / declination plane
("Trajectory" figures), and the time histories of the MRPs, the angular velocity and
the torque ("Time History of the States"). :data:`FIGURES` lists them, plus the margin
of every constraint against time; :func:`figures_for` adds the estimation figure for
runs flown on an estimate, the wheel figure for runs flown by a reaction wheel array
(:func:`flies_on_wheels`) and the goals figure for runs with goals; a run with none of
them gets exactly :data:`FIGURES`. No plotting
here.

Keep-in cones (a body axis that must stay within an angle of an inertial direction)
appear wherever keep-out cones do, drawn dashed in green and labelled ``keep_in/<name>``
(the summary's constraint label): the allowed cone on the sky, the axis' inertial track
in its own panel of the boresight figure, the boundary in MRP space and its margin
against time. Their artists carry ``gid`` ``keep_in/<name>/<part>`` (``cone``,
``axis``, ``surface``, ``margin``), so a test can find them.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..data import ReportRun

__all__ = [
    "FIGURES",
    "ESTIMATION_FIGURES",
    "WHEEL_ARRAY_FIGURES",
    "GOAL_FIGURES",
    "figures_for",
    "flies_on_wheels",
]

# file name -> (title, what it shows); the order of the report.
FIGURES = {
    "keepout_inertial.png": (
        "Keep-out cones in the inertial frame",
        "Each cone (the instrument's half-angle about the bright object) drawn as a true "
        "small circle on the sky, right ascension / declination (paper: Keep-Out "
        "Constraints, inertial space); each keep-in cone (the largest angle allowed about "
        "its direction) dashed in green.",
    ),
    "keepout_mrp.png": (
        "Keep-out regions in MRP space",
        "Zero level set of the margin of each instrument/object pair inside the unit ball "
        "|sigma| <= 1 (marching cubes, clipped at the unit sphere, drawn as a wireframe) "
        "(paper: Keep-Out Constraints, MRP space); each keep-in cone's boundary (the zero "
        "level set of its margin) as a faint green surface, start and goal on its allowed "
        "side.",
    ),
    "trajectory_mrp.png": (
        "MRP trajectory among the keep-out regions",
        "Body sigma_BN (solid) and planner target sigma_t (dashed) in MRP space; start "
        "and goal marked (paper: MRP vector trajectory).",
    ),
    "trajectory_boresight.png": (
        "Boresight trajectory on the sky",
        "Each instrument's boresight C_BN^T s_i on the right ascension / declination "
        "plane among its keep-out cones, and each keep-in axis C_BN^T a_k with its allowed "
        "cone (dashed green); start and goal marked (paper: boresight vector trajectory).",
    ),
    "history_mrp.png": (
        "Time history of the MRPs",
        "Components of sigma_BN (solid) and of the target sigma_t (dashed); attitude "
        "error to the goal (paper: time history, MRPs).",
    ),
    "history_rate.png": (
        "Time history of the angular velocity",
        "Body rate omega_BN components and norm, rad/s (paper: time history, angular velocity).",
    ),
    "history_torque.png": (
        "Time history of the control torque",
        "Control torque components (body axes) and norm, N m (paper: time history, torque).",
    ),
    "margin.png": (
        "Constraint margins against time",
        "Angle between boresight and object minus the half-angle, for each "
        "instrument/object pair; for each keep-in cone (dashed, keep_in/<name>) the largest "
        "angle allowed minus the angle between its axis and its direction; negative is a "
        "violation.",
    ),
}

ESTIMATION_FIGURES = {
    "estimation.png": (
        "Estimate against truth",
        "Runs with sensors: the principal angle between the estimated attitude the loop was "
        "fed and the true body (deg) under the estimator's 3-sigma (3 sqrt(trace P_att), "
        "shaded), and the error of the bias-corrected rate estimate (rad/s); the knowledge "
        "3-sigma the guidance planned with dotted.",
    ),
}
"""Figures only for runs that were flown on an estimate (``RunResult.estimate``)."""

WHEEL_ARRAY_FIGURES = {
    "wheels.png": (
        "Reaction wheels",
        "Runs with wheels: each wheel's speed relative to the body (rpm) and the motor "
        "torque it applied (N m, held over each step) against its limits (dashed, +/-; grey "
        "when every wheel has the same limit); the change since t = 0 of the system angular "
        "momentum in inertial axes, C_BN^T (J omega + sum_i g_i Js_i Omega_i) (N m s): flat "
        "at zero without external torque, drifting by the integral of a disturbance (the "
        "gravity gradient). The titles give the peak speed and torque as fractions of the "
        "limits, the momentum's size at t = 0 and its unexplained change: the largest "
        "change the integrated external torque does not explain (summary.json's "
        "peak_wheel_speed_frac, peak_wheel_torque_frac, momentum_error_nms).",
    ),
}
"""Figures only for runs flown by a reaction wheel array (:func:`flies_on_wheels`)."""


GOAL_FIGURES = {
    "goals.png": (
        "Goals",
        "Runs with goals (a plan's targets, goals received on <run namespace>/planner/goal): "
        "one row per goal, in order. Left: the first instrument's boresight on the right "
        "ascension / declination plane while the goal was in force, among its keep-out "
        "cones, from where the body was (open marker) to the goal (filled). Right: every "
        "constraint's margin over that window (deg; negative is a violation), the arrival "
        "dotted. A goal never in force (refused, skipped) says why.",
    ),
}
"""Figures only for runs with goals (``RunResult.goals``)."""


def flies_on_wheels(run: ReportRun) -> bool:
    """Whether ``run`` was flown by a wheel array and its record holds the wheels."""
    return run.scenario.wheels is not None and run.run.wheels is not None


def figures_for(runs: Sequence[ReportRun]) -> dict[str, tuple[str, str]]:
    """The figures of a report on ``runs``: :data:`FIGURES`, the estimation figure when a
    run was flown on an estimate, the wheel figure when a run was flown by wheels."""
    figures = dict(FIGURES)
    if any(r.run.estimate is not None for r in runs):
        figures.update(ESTIMATION_FIGURES)
    if any(flies_on_wheels(r) for r in runs):
        figures.update(WHEEL_ARRAY_FIGURES)
    if any(r.run.goals for r in runs):
        figures.update(GOAL_FIGURES)
    return figures
