"""Physics core: parameters, the immutable model, dense reference dynamics, the compiled O(n)
kernel, statics and input signals.

May import numpy, scipy and numba only; never rclpy, matplotlib or mcap, nor any other cable_sim layer.
"""
