"""ROS 2 adapter: the node, its messages and the MCAP recorder.

- :mod:`.node` — ``CableSimNode`` (composes the pieces below) and ``main`` (console script
  ``cable_sim_node``);
- :mod:`.parameters` (+ :mod:`.scene_docs`, :mod:`.command_line`) — declarations, descriptors,
  validation; :mod:`.clock_modes` — realtime / fast / lockstep pacing; :mod:`.stepping` — one
  step and the outputs due; :mod:`.timing` — pauses and the real-time factor;
  :mod:`.topic_inputs`, :mod:`.publishers`, :mod:`.services`, :mod:`.diagnostics`,
  :mod:`.recording` — one side of the interface each;
- :mod:`.messages` — the message layout; :mod:`.recorder` — the MCAP recorder package.

May import rclpy, mcap and the layers below (scene, integrate, core); never :mod:`cable_sim.analysis`.
"""
