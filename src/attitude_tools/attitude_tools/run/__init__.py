"""``attitude-run``: the node graph started as processes on a ROS domain of its own,
stopped, and its bag turned into a run summary."""
