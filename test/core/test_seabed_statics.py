"""Issue 11, item 1: a line resting on the seabed against the inextensible catenary with touchdown.

Reference (written here from MODEL.md, not from ``cable_sim.core.statics``): with the anchor on a
horizontal seabed, vertical rise V of the fairlead above the bed, horizontal span D and length L,
the suspended part of a line of wet weight w per length is a catenary with its vertex at the
touchdown point: for a catenary parameter a = H / w it has L_s = sqrt(V^2 + 2 a V) and horizontal
extent a asinh(L_s / a); the laid length is L_b = L - L_s and must close the span,
a asinh(L_s/a) + L_b = D. This is solved for a by bisection here. Fairlead force: H horizontal,
w L_s vertical.

The static solution (n = 80, no bending stiffness, stiff bed so its elastic give is small) must give
the touchdown point (arc length from the anchor within 1 % of the laid length, its x within 1 % of
the span and within one link length) and the fairlead tension (and its horizontal part) within
1 % of the reference for three anchor positions, be a dynamic equilibrium (qdd ~ 0), and the laid part must
sink into the bed by w / k_b within 10 %.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from cable_sim.core import dynamics, seabed
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.statics import static_equilibrium

L = 300.0
MPL = 115.0  # kg/m
D_EQ = 0.137  # m
RHO_W = 1025.0
G = 9.81
W = (MPL - RHO_W * np.pi * D_EQ**2 / 4) * G  # wet weight per length [N/m]
DEPTH = 100.0
K_BED = 1.0e6  # N/m^2: static penetration W / K_BED ~ 1 mm


def reference(D: float, V: float) -> dict[str, float]:
    """Catenary with touchdown (bisection in a); returns laid length, H, fairlead tension."""

    def closing(a: float) -> float:
        ls = np.sqrt(V * V + 2 * a * V)
        return a * np.arcsinh(ls / a) + (L - ls) - D

    a = brentq(closing, 1e-6, 1e6, xtol=1e-12, rtol=1e-14)
    ls = np.sqrt(V * V + 2 * a * V)
    H = W * a
    return {"laid": L - ls, "H": H, "T": float(np.hypot(H, W * ls)), "x_td": D - (L - ls)}


def line(anchor_x: float, n: int = 80, **kw) -> CableModel:
    p = CableParams(
        n_links=n, total_length=L, diameter=D_EQ, mass_per_length=MPL, water_density=RHO_W, gravity=G,
        stiffness_mode="bending", bending_stiffness=0.0, bending_damping=0.0, pin_stiffness=0.0,
        platform_mass=2e5, heave_stiffness=5e5, heave_damping=5e4, load_mass=0.0, drag_model="none",
        end_condition="anchored", anchor_x=anchor_x, anchor_z=-DEPTH, seabed=True,
        seabed_depth=-DEPTH, seabed_stiffness=kw.pop("k", K_BED), seabed_damping=0.0, **kw,
    )
    return CableModel.from_params(p)


@pytest.mark.parametrize("anchor_x", [220.0, 250.0, 270.0])
def test_touchdown_and_fairlead_tension_match_catenary(anchor_x: float) -> None:
    model = line(anchor_x)
    q, lam = static_equilibrium(model)
    qd = np.zeros_like(q)
    qdd, anchor = dynamics.forward_dynamics(model, q, qd)
    F = dynamics.joint_forces(model, q, qd, qdd, anchor)
    V = q[0] - (-DEPTH)
    ref = reference(anchor_x, V)
    td = seabed.seabed_outputs(model, q)
    err_td = (td.touchdown_arc - ref["laid"]) / ref["laid"]
    err_x = (td.touchdown_x - ref["x_td"]) / anchor_x  # of the span (x_td's origin is arbitrary)
    err_T = np.linalg.norm(F[0]) / ref["T"] - 1.0
    err_H = abs(F[0, 0]) / ref["H"] - 1.0
    print(f"anchor x = {anchor_x}: laid {td.touchdown_arc:.3f} m (ref {ref['laid']:.3f}, {err_td:+.2e}), "
          f"touchdown x {td.touchdown_x:.3f} m (ref {ref['x_td']:.3f}, {err_x:+.2e}), fairlead tension "
          f"{np.linalg.norm(F[0]):.1f} N (ref {ref['T']:.1f}, {err_T:+.2e}), H {err_H:+.2e}, "
          f"max|qdd| {np.max(np.abs(qdd)):.1e}")
    assert ref["laid"] > 50.0  # the case does have a laid part
    assert abs(err_td) < 0.01 and abs(err_x) < 0.01
    assert abs(td.touchdown_x - ref["x_td"]) < L / 80  # within one link of the reference
    assert abs(err_T) < 0.01 and abs(err_H) < 0.01
    assert np.max(np.abs(qdd)) < 1e-6


def test_static_penetration_is_weight_over_stiffness() -> None:
    """Soft bed (k_b = 2e4 N/m^2: ~5 cm): the joints well inside the laid part sit w / k_b deep."""
    k = 2.0e4
    model = line(250.0, k=k)
    q, _ = static_equilibrium(model)
    p = dynamics.joint_positions(model, q)
    ref = reference(250.0, q[0] + DEPTH)
    s_anchor = L - np.concatenate([[0.0], np.cumsum(model.length)])  # arc length from the anchor
    inner = (s_anchor > 0.25 * ref["laid"]) & (s_anchor < 0.75 * ref["laid"])
    pen = -DEPTH - p[inner, 1]
    print(f"penetration {pen.min():.5f} .. {pen.max():.5f} m, w / k_b = {W / k:.5f} m")
    assert np.all(np.abs(pen / (W / k) - 1.0) < 0.10)


def test_no_seabed_is_unchanged() -> None:
    """Seabed off: the same line hangs below the anchor depth (the issue's bug) — the term is
    really switched off, and on, no joint is deeper than the bed's give."""
    off = CableModel.from_params(line(250.0).params.replace(seabed=False))
    q_off, _ = static_equilibrium(off)
    assert dynamics.joint_positions(off, q_off)[:, 1].min() < -DEPTH - 10.0
    on = line(250.0)
    q_on, _ = static_equilibrium(on)
    assert dynamics.joint_positions(on, q_on)[:, 1].min() > -DEPTH - 3 * W / K_BED
