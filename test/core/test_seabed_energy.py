"""Issue 11, item 3 (and the added-mass power of item 4): energy balance with seabed contact,
contact damping, friction and added mass; a line dropped onto the seabed comes to rest on it.

E = T + V, V including the bed's elastic energy int 1/2 k_b delta^2 ds (dense reference). Every
non-conservative force's power is integrated alongside the state (extra ODE component): joint
dampers, Morison drag, the bed's damping and friction (``power()['seabed']``) and the added
mass's force (``power()['added_mass']``, -qd . (M_a qdd + b_a)). With DOP853 at rtol 1e-11,
E(t) - E(0) must equal the integrated power to 1e-5 of the energy that went through the forces.

Settling: an anchored line (45 m, anchor on the bed 30 m across and 20 m down) hangs at rest from
a platform held 12 m up; the platform is released onto its heave spring and the line drops onto
the bed. Its regularised friction cannot hold a line at rest against a pull (it creeps), so the
line must come to rest at a true equilibrium: the anchored touchdown shape. Over 110-120 s every
joint moves slower than 1 mm/s (no contact jitter), part of the line lies on the bed, the joints
inside the laid part sit w / k_b deep (within 10 %) and the lowest point does not sink further
over those 10 s (0.1 mm).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cable_sim.core import dynamics, seabed
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.statics import static_equilibrium
from cable_sim.core.system import CableSystem

ZB, K_B = -30.0, 2.0e4
D, MPL, RHO_W, G = 0.1, 50.0, 1025.0, 9.81
W = (MPL - RHO_W * np.pi * D**2 / 4) * G


def model(**kw) -> CableModel:
    base = dict(
        n_links=10, total_length=40.0, diameter=D, mass_per_length=MPL, water_density=RHO_W, gravity=G,
        stiffness_mode="bending", bending_stiffness=50.0, bending_damping=20.0, heave_locked=True,
        load_mass=0.0, drag_model="morison", drag_cn=1.2, drag_ct=0.1, seabed=True, seabed_depth=ZB,
        seabed_stiffness=K_B, seabed_damping=2.0e3, seabed_friction_axial=0.5,
        seabed_friction_transverse=0.8, seabed_friction_speed=0.05, added_mass=True,
        added_mass_cn=1.0, added_mass_ct=0.2)
    return CableModel.from_params(CableParams(**{**base, **kw}))


def _rhs(m: CableModel):
    k = m.ndof

    def f(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = y[:k], y[k:2 * k]
        qdd, lam = dynamics.forward_dynamics(m, q, qd)
        P = dynamics.power(m, q, qd, anchor_force=lam, qdd=qdd)
        return np.concatenate([qd, qdd, [sum(P.values())], [abs(P["seabed"])]])

    return f


def _drop_state(m: CableModel) -> np.ndarray:
    return np.concatenate([np.zeros(1), np.full(m.n, np.deg2rad(60.0)), np.zeros(m.ndof)])


def test_energy_balance_with_contact_friction_and_added_mass() -> None:
    m = model()
    k = m.ndof
    y0 = np.concatenate([_drop_state(m), [0.0, 0.0]])
    sol = solve_ivp(_rhs(m), (0.0, 12.0), y0, method="DOP853", rtol=1e-11, atol=1e-11,
                    dense_output=False, t_eval=np.linspace(0, 12.0, 121))
    assert sol.success
    E = np.array([dynamics.total_energy(m, y[:k], y[k:2 * k]) for y in sol.y.T])
    work = sol.y[2 * k]
    bed_work = sol.y[2 * k + 1]
    lowest = min(dynamics.joint_positions(m, y[:k])[:, 1].min() for y in sol.y.T)
    err = np.max(np.abs(E - E[0] - work)) / np.max(np.abs(work))
    print(f"energy dissipated {-work[-1]:.6g} J (seabed damping + friction {bed_work[-1]:.4g} J), "
          f"max |E - E0 - int P| / max|int P| = {err:.2e}, lowest point {lowest:.4f} m")
    assert lowest < ZB  # the line did hit the bed
    assert bed_work[-1] > 1e-3 * abs(work[-1])  # the bed's damping and friction did work
    assert err < 1e-5


@pytest.mark.parametrize("friction", [True, False])
def test_dropped_line_comes_to_rest_on_the_bed(friction: bool) -> None:
    zb = -20.0
    kw = dict(n_links=16, total_length=45.0, end_condition="anchored", anchor_x=30.0, anchor_z=zb,
              seabed_depth=zb, bending_damping=2000.0, drag_cn=2.4, drag_ct=0.4, platform_mass=2000.0,
              heave_stiffness=2.0e4, heave_damping=1.0e4)
    if not friction:
        kw.update(seabed_friction_axial=0.0, seabed_friction_transverse=0.0)
    m = model(**kw, heave_locked=False)
    held = model(**kw, heave_locked=True)
    q0, _ = static_equilibrium(held, z_top=12.0)
    k = m.ndof
    assert dynamics.joint_positions(m, q0)[:-1, 1].min() > zb  # starts clear of the bed

    # 120 s of settling on the O(n) compiled kernel (the dense one is ~100x slower here; the two
    # agree to 1e-9 of scale on contact states, test_seabed_fast_kernel)
    f = CableSystem(m, kernel="fast").rhs
    sol = solve_ivp(f, (0.0, 120.0), np.concatenate([q0, np.zeros(k)]), method="DOP853", rtol=1e-7,
                    atol=1e-9, t_eval=np.linspace(110.0, 120.0, 101))
    assert sol.success
    speeds = [np.abs(dynamics.joint_velocities(m, y[:k], y[k:])).max() for y in sol.y.T]
    lows = [dynamics.joint_positions(m, y[:k])[:, 1].min() for y in sol.y.T]
    y = sol.y[:, -1]
    z = dynamics.joint_positions(m, y[:k])[:, 1]
    below = z < zb
    # joints with two links on the bed on either side (away from the anchor and the touchdown)
    inside = below[:-4] & below[1:-3] & below[2:-2] & below[3:-1] & below[4:]
    pen = zb - z[2:-2][inside]
    out = seabed.seabed_outputs(m, y[:k], y[k:])
    print(f"friction {friction}: max joint speed over 110-120 s {max(speeds):.2e} m/s, laid "
          f"{out.laid_length:.2f} m, laid joints {pen.size} sunk {pen.min():.5f}..{pen.max():.5f} m "
          f"(w/k_b = {W / K_B:.5f} m), lowest point {lows[-1] - zb:+.5f} m (change over 10 s "
          f"{lows[-1] - lows[0]:+.1e} m), reaction {out.reaction:.1f} N")
    assert max(speeds) < 1e-3
    assert out.laid_length > 10.0 and pen.size >= 2
    assert np.all(np.abs(pen / (W / K_B) - 1.0) < 0.10)
    assert abs(lows[-1] - lows[0]) < 1e-4
