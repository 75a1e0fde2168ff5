"""Run tooling without rclpy: rosbag2 MCAP bags, ``attitude-run``, the ``ros2 run`` shim."""
