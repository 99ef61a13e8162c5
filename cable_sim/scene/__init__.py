"""Scenes and runs: scene files, the automatic choice of n / integrator / step, and the
:class:`~cable_sim.scene.simulation.Simulation` runner that the node, the replay tool and batch
studies share.

May import :mod:`cable_sim.core` and :mod:`cable_sim.integrate`; never rclpy, matplotlib or mcap.
"""
