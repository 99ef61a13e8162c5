"""Issue #2, item 4: static anchored line vs an inextensible catenary solved in this file.

Line without bending stiffness (joint springs off, free pin), no load, heave locked, fairlead
at (0, 0), end anchored at (X, Z). The reference is the inextensible catenary written in terms
of the fairlead force components (H horizontal, V0 vertical) and the arc length s from the
fairlead, with w = m~ g / l the wet weight per metre (computed here from the densities):

    x(s) = (H/w) [asinh((w s - V0)/H) + asinh(V0/H)]
    z(s) = (H/w) [sqrt(1 + ((w s - V0)/H)^2) - sqrt(1 + (V0/H)^2)]

(H, V0) are found with scipy.optimize.fsolve from x(L) = X, z(L) = Z; the fairlead tension is
sqrt(H^2 + V0^2). Neither ``statics.catenary_points`` nor any package catenary code is used.

The package's rest state comes from ``statics.static_equilibrium``; it must also be a dynamic
equilibrium (``forward_dynamics`` gives ~0 accelerations, dense and fast kernels), and the
fairlead tension is |dynamics.joint_forces(...)[0]| at that state. Compared: the fairlead
tension (relative), the max distance of the joints from the catenary curve (relative to L) and,
stricter, the distance of joint k from the catenary point at the same arc length s = k l.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import fsolve

from cable_sim import dynamics, fast
from cable_sim.model import CableModel
from cable_sim.params import CableParams
from cable_sim.statics import static_equilibrium

L = 240.0
D = 0.01
RHO_C, RHO_W, G = 7850.0, 1025.0, 9.81
W = (RHO_C - RHO_W) * np.pi * D**2 / 4 * G  # wet weight per metre [N/m]


def _curve(H: float, V0: float, s: np.ndarray) -> np.ndarray:
    u = (W * s - V0) / H
    x = H / W * (np.arcsinh(u) + np.arcsinh(V0 / H))
    z = H / W * (np.sqrt(1 + u**2) - np.sqrt(1 + (V0 / H) ** 2))
    return np.stack([x, z], axis=-1)


def _solve_catenary(X: float, Z: float) -> tuple[float, float]:
    def eqs(v):
        H, V0 = np.exp(v[0]), v[1]
        return _curve(H, V0, np.array(L)) - np.array([X, Z])

    best = None
    for H0 in (0.1 * W * L, 0.5 * W * L, 2 * W * L):
        for V00 in (0.0, 0.5 * W * L, W * L):
            v, info, ier, _ = fsolve(eqs, [np.log(H0), V00], full_output=True, xtol=1e-14)
            r = float(np.max(np.abs(eqs(v))))
            if best is None or r < best[0]:
                best = (r, float(np.exp(v[0])), float(v[1]))
    r, H, V0 = best
    assert r < 1e-9 * L, f"catenary solve did not converge (residual {r:.3e} m)"
    return H, V0


def _distance_to_curve(pts: np.ndarray, H: float, V0: float) -> np.ndarray:
    s = np.linspace(0.0, L, 200001)
    c = _curve(H, V0, s)
    out = np.empty(len(pts))
    for i, p in enumerate(pts):
        d = np.hypot(c[:, 0] - p[0], c[:, 1] - p[1])
        j = int(np.argmin(d))
        best = d[j]
        for k in (j - 1, j):  # refine on the neighbouring segments of the fine polyline
            if 0 <= k < len(s) - 1:
                a, b = c[k], c[k + 1]
                t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
                best = min(best, float(np.linalg.norm(p - (a + t * (b - a)))))
        out[i] = best
    return out


@pytest.mark.parametrize("anchor", [(180.0, -120.0), (100.0, -200.0)])
@pytest.mark.parametrize("n", [20, 80])
def test_anchored_line_is_a_catenary(n, anchor):
    X, Z = anchor
    p = CableParams(n_links=n, total_length=L, diameter=D, line_density=RHO_C,
                    water_density=RHO_W, gravity=G, joint_springs=False, pin_stiffness=0.0,
                    load_mass=0.0, end_condition="anchored", anchor_x=X, anchor_z=Z,
                    heave_locked=True, drag_model="none")
    model = CableModel.from_params(p)
    q, _ = static_equilibrium(model, z_top=0.0)
    qd = np.zeros(n + 1)

    # a static equilibrium must be a dynamic one: nothing accelerates (dense and fast kernels)
    qdd, lam = dynamics.forward_dynamics(model, q, qd)
    qdd_f, _ = fast.forward_dynamics(model, q, qd)
    acc = max(np.max(np.abs(qdd)), np.max(np.abs(qdd_f)))
    assert acc < 1e-9, acc

    pts = dynamics.joint_positions(model, q)
    assert np.allclose(pts[0], [0.0, 0.0], atol=1e-12)
    assert np.allclose(pts[-1], [X, Z], atol=1e-8)

    H, V0 = _solve_catenary(X, Z)
    T_ref = float(np.hypot(H, V0))
    T = float(np.linalg.norm(dynamics.joint_forces(model, q, qd, qdd, lam)[0]))
    t_err = abs(T - T_ref) / T_ref
    shape_err = float(np.max(_distance_to_curve(pts, H, V0))) / L
    s = np.arange(n + 1) * (L / n)
    station_err = float(np.max(np.linalg.norm(pts - _curve(H, V0, s), axis=1))) / L
    print(f"\nn={n} anchor=({X:g},{Z:g}): fairlead T {T:.4f} N vs catenary {T_ref:.4f} N "
          f"(rel {t_err:.2e}); shape max dist/L {shape_err:.2e}; same-s dist/L "
          f"{station_err:.2e}; max |qdd| {acc:.1e}")
    assert t_err < 0.01
    assert shape_err < 0.01
    assert station_err < 0.01
