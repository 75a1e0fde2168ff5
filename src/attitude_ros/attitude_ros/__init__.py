"""ROS 2 glue shared by the attitude nodes."""
