"""Issue 11, item 7: the touchdown point under a slow heave moves as quasi-static catenary theory
predicts.

The mooring line (seabed and added mass on, n = 30) is driven by a slow regular wave (2 m, 90 s:
far slower than the buoy's 4 s heave period and the line's swing, so the line passes through
near-static shapes). Reference, written here from MODEL.md ("Catenary with touchdown", not the
package's statics): for the buoy's simulated height z_f(t), the inextensible catenary with
touchdown (bisection in a = H / w) gives the touchdown x = D - L_b.

A chain of rigid links touches the bed at a hinge: its geometric touchdown point (the uppermost
point below the bed level, package output ``touchdown_x``) sticks at a joint while the link above
it lifts, then jumps by a link length — a staircase of step l. The bed carries the weight of the
laid part (the line is horizontal at the touchdown, so no vertical force passes it), so the
total seabed reaction R (package output ``reaction``) gives a smooth touchdown x = D - R / w.
Over the last full wave cycle that touchdown x must move with the reference (correlation > 0.95)
with the same excursion max - min within 10 %, and the geometric touchdown's excursion must match
the reference's within one link length.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from cable_sim.core import seabed
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

PERIOD, AMP = 90.0, 2.0


def touchdown_x_reference(D: float, V: float, L: float, w: float) -> float:
    def closing(a: float) -> float:
        ls = np.sqrt(V * V + 2 * a * V)
        return a * np.arcsinh(ls / a) + (L - ls) - D

    a = brentq(closing, 1e-6, 1e6, xtol=1e-12)
    return D - (L - np.sqrt(V * V + 2 * a * V))


def test_touchdown_follows_quasi_static_catenary() -> None:
    scene = load_scene("mooring_line", {
        "n_links": 30, "seabed": True, "added_mass": True, "wave_source": "regular_wave",
        "wave_amplitude": AMP, "wave_period": PERIOD, "wave_ramp": 0.0, "kernel": "fast"})
    sim = Simulation(scene, kernel="fast")  # the O(n) kernel (checked against the dense one elsewhere)
    model, system = sim.model, sim.system
    p = scene.params
    w = (p.mass_per_length - p.water_density * np.pi * p.diameter[0] ** 2 / 4) * p.gravity
    k = model.ndof
    t_eval = np.linspace(PERIOD, 2 * PERIOD, 91)
    sol = solve_ivp(system.rhs, (0.0, 2 * PERIOD), sim.y0, method="DOP853", rtol=1e-7, atol=1e-8,
                    t_eval=t_eval)
    assert sol.success
    outs = [seabed.seabed_outputs(model, y[:k], y[k:]) for y in sol.y.T]
    geo_x = np.array([o.touchdown_x for o in outs])
    sim_x = p.anchor_x - np.array([o.reaction for o in outs]) / w
    ref_x = np.array([touchdown_x_reference(p.anchor_x, y[0] - p.anchor_z, p.total_length, w)
                      for y in sol.y.T])
    heave = sol.y[0]
    corr = np.corrcoef(sim_x, ref_x)[0, 1]
    ex_sim, ex_ref = np.ptp(sim_x), np.ptp(ref_x)
    print(f"heave {heave.min():+.3f}..{heave.max():+.3f} m; touchdown x from R/w "
          f"{sim_x.min():.2f}..{sim_x.max():.2f} m "
          f"(reference {ref_x.min():.2f}..{ref_x.max():.2f} m); excursion {ex_sim:.3f} m vs {ex_ref:.3f} m "
          f"({ex_sim / ex_ref - 1:+.2%}), correlation {corr:.4f}; rises with the buoy: "
          f"{np.corrcoef(sim_x, heave)[0, 1]:+.3f}")
    print(f"geometric touchdown x {geo_x.min():.2f}..{geo_x.max():.2f} m: excursion {np.ptp(geo_x):.3f} m "
          f"(link length {model.length[0]:.1f} m)")
    assert np.ptp(heave) > 3.0  # the buoy does heave
    assert corr > 0.95
    assert abs(ex_sim / ex_ref - 1.0) < 0.10
    assert abs(np.ptp(geo_x) - ex_ref) < model.length[0]
