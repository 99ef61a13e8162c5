"""Issue #2, item 8: both paper scenes run end to end; the unforced free fall never gains energy.

- ``paper_free_fall`` (31 s) and ``paper_anchored_forced`` (15.5 s) run with kernel ``fast`` and
  their own integrators and steps through ``runner.Simulation``; every output sample (every
  0.02 s) must be finite: state, tensions, energy.
- Free fall is unforced and every non-conservative term in it dissipates (paper drag, joint and
  heave dampers), so the total energy must never increase between samples. The energy is
  computed here independently (conftest.RefLine, explicit loops from MODEL.md) and must also
  agree with the package's reported ``Outputs.energy``. Slack for RK4's own (non-monotone)
  energy error: 1e-9 of the energy scale per sample, the scale being the energy released over
  the run, E(0) - min E (datum-independent; E(0) itself depends on where V = 0 is).
"""

from __future__ import annotations

import numpy as np
from conftest import RefLine

from cable_sim.runner import Simulation
from cable_sim.scenes import load_scene

DT_OUT = 0.02


def _run(sim: Simulation, t_end: float):
    outs = [sim.outputs()]
    k = 0
    while sim.t < t_end - 1e-9:
        k += 1
        sim.run_until(min(k * DT_OUT, t_end))
        outs.append(sim.outputs())
    return outs


def _finite(o) -> bool:
    return bool(np.all(np.isfinite(o.q)) and np.all(np.isfinite(o.qd))
                and np.all(np.isfinite(o.axial_tension)) and np.isfinite(o.energy)
                and np.isfinite(o.fairlead_tension))


def test_free_fall_31s_finite_and_energy_never_increases():
    scene = load_scene("paper_free_fall", {"kernel": "fast"})
    assert scene.sim["heave_force_source"] == "none" and scene.sim["wave_source"] == "none"
    sim = Simulation(scene)
    outs = _run(sim, 31.0)
    assert abs(outs[-1].t - 31.0) < 1e-9 and len(outs) == round(31.0 / DT_OUT) + 1
    assert all(_finite(o) for o in outs)
    ref = RefLine(scene.params)
    E = np.array([ref.energy(o.q, o.qd) for o in outs])
    E_pkg = np.array([o.energy for o in outs])
    scale = E[0] - E.min()
    rise = float(np.max(np.diff(E)))
    print(f"\nfree fall ({sim.integrator.name} {sim.h * 1e3:g} ms, n={sim.model.n}): E(0) = "
          f"{E[0]:.6g} J, energy released {scale:.6g} J; largest {DT_OUT:g} s change "
          f"{rise:.4g} J (slack {1e-9 * scale:.3g} J); |E_pkg - E_ref| max "
          f"{np.max(np.abs(E_pkg - E)):.2e} J")
    assert scale > 1e4  # the line really falls and dissipates
    assert np.max(np.abs(E_pkg - E)) < 1e-9 * scale
    assert rise <= 1e-9 * scale


def test_anchored_forced_15_5s_finite():
    scene = load_scene("paper_anchored_forced", {"kernel": "fast"})
    assert scene.sim["heave_force_source"] != "none"
    sim = Simulation(scene)
    outs = _run(sim, 15.5)
    assert abs(outs[-1].t - 15.5) < 1e-9 and len(outs) == round(15.5 / DT_OUT) + 1
    assert all(_finite(o) for o in outs)
    z = np.array([o.q[0] for o in outs])
    T = np.array([o.fairlead_tension for o in outs])
    print(f"\nanchored forced ({sim.integrator.name} {sim.h * 1e3:g} ms, n={sim.model.n}): heave "
          f"{z.min():.3f}..{z.max():.3f} m, fairlead tension {T.min():.1f}..{T.max():.1f} N")
    assert z.max() - z.min() > 1.0
