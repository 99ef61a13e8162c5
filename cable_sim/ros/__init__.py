"""ROS 2 adapter: the node, its messages and the MCAP recorder.

May import rclpy, mcap and the layers below (scene, integrate, core); never :mod:`cable_sim.analysis`.
"""
