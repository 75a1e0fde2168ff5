"""ROS-free core of the constrained attitude reorientation stack.

Plain NumPy, no global state: the same functions run in unit tests, offline batch
runs and the ROS 2 nodes. Equation numbers refer to Choi, Kim and Leeghim,
"Constrained Attitude Reorientation Maneuver of Spacecraft based on Path Planning"
(AAS 24-295).
"""
