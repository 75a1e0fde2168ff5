"""Example hardware-in-the-loop bridge: a plant behind the stack's topic contract.

``plant.py`` is the plant interface and a SciPy rigid body; ``bridge_node.py`` is the
ROS 2 node (``ros2 run spacecraft_bridge_example bridge``). See docs/hil_bridge.md.
"""
