"""Read, plot, export and re-simulate a recorded run (an MCAP file written by the node).

Everything here works on the file alone (``mcap`` + ``mcap_ros2`` decoder, no ROS graph):

- :func:`load_run` (:mod:`.load`) decodes the recorded topics into arrays (:class:`Run`) and
  rebuilds the scene from the ``"scene"`` metadata record; :mod:`.cdr` holds the hand-written
  decoders of the large message types;
- :func:`summary` (:mod:`.report`) prints scene, duration, achieved real-time factor, max/RMS
  fairlead tension, max tip excursion, rejected inputs and overruns, and with a seabed the
  touchdown excursion (x range), touchdown arc-length range and laid-length range
  (:func:`seabed_values`); :func:`export_csv`;
- :func:`plot_frames` (configurations as frames, like Figs. 9 and 10 of Pouzada & Gomes),
  :func:`plot_tension` (:mod:`.plots`), :func:`animate` (GIF, :mod:`.gif`);
- :func:`resimulate` (:mod:`.resim`) runs :class:`cable_sim.scene.simulation.Simulation` again
  from the recorded ``applied_inputs`` (optionally with another n, integrator, step or kernel)
  and :func:`compare` reports the difference from the recording; with the recorded settings it
  is exactly zero;
- :func:`record_headless` (:mod:`.headless`) runs a scene without ROS and records the same
  topics and message types the node publishes (for documentation figures and tests of the
  recorder);
- ``cable_sim_replay`` (:mod:`.cli`); ``--recover BAD.mcap FIXED.mcap`` repairs a file cut short
  by SIGKILL.

Timing convention of ``applied_inputs``: a value recorded with log time ``t_ns`` is held from
step ``k = round(t_ns / (h * 1e9))`` on (``h`` the recorded step), i.e. over the step from k to
k + 1; the outputs stamped k were published before it was applied (as the node does); with
another step ``h'`` it applies from ``round(t_ns / (h' * 1e9))``.

This package is the analysis layer: it may import every layer (core, integrate, scene, ros).
"""

from .cli import main
from .gif import animate, gif_frame_indices
from .headless import record_headless
from .load import LOADABLE, PROGRESS_MIN_MESSAGES, TOPICS, Run, Series, load_run, read_metadata, scene_of
from .plots import plot_frames, plot_tension
from .report import export_csv, seabed_values, summary, summary_values
from .resim import Resim, compare, resimulate

__all__ = [
    "LOADABLE", "PROGRESS_MIN_MESSAGES", "TOPICS", "Resim", "Run", "Series", "animate", "compare",
    "export_csv", "gif_frame_indices", "load_run", "main", "plot_frames", "plot_tension", "read_metadata",
    "record_headless", "resimulate", "scene_of", "seabed_values", "summary", "summary_values",
]
