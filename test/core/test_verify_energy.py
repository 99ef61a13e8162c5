"""Issue #2: energy balance.

1. Drag, joint dampers, platform damper and forcing off: E = T + V is a constant of motion.
   With DOP853 at rtol = atol = 1e-12 over 20 s the drift max|E(t) - E(0)| must stay below
   1e-7 of the peak kinetic energy. Kinetic energy is used as the scale because it does not
   depend on the (arbitrary) datum of the potential energy, whereas |E| does.
2. Everything on (paper or Morison drag with a current, joint and heave dampers, a sine heave
   force and a wave at the platform): E(t) - E(0) must equal the work of the non-conservative
   forces, the time integral of ``sum(dynamics.power(...).values())``. The power is integrated
   in the same solve_ivp call as the state (augmented ODE), so both carry the same time error;
   agreement to 1e-5 of the work is required.

The energy functions are checked independently: T = 1/2 qd^T M qd against the sympy derivation
(test_verify_sympy.py) and here V against its definition from joint positions.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cable_sim.core import dynamics
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate import ScipyIntegrator

N = 10
T_END = 20.0


def _initial(model: CableModel, rng: np.random.Generator) -> np.ndarray:
    q = np.concatenate([[0.5], np.linspace(0.3, 1.4, model.n) + rng.uniform(-0.1, 0.1, model.n)])
    qd = np.concatenate([[0.2], rng.uniform(-0.2, 0.2, model.n)])
    return np.concatenate([q, qd])


def _independent_potential(p: CableParams, q: np.ndarray) -> float:
    """V from MODEL.md written out here: wet weight at link centres and load, springs."""
    n, l = p.n_links, p.lengths()
    area = np.pi * np.asarray(p.diameter) ** 2 / 4
    mw = (np.asarray(p.line_density) - p.water_density) * area * l
    mcw = p.load_mass - p.water_density * p.load_volume
    z = q[0] - np.concatenate([[0.0], np.cumsum(l * np.cos(q[1:]))])
    V = p.gravity * (np.sum(mw * 0.5 * (z[:-1] + z[1:])) + mcw * z[-1])
    V += 0.5 * p.heave_stiffness * q[0] ** 2 if p.platform_spring else 0.0
    k = np.full(n, p.joint_stiffness)
    k[0] = p.pin_stiffness
    if p.joint_springs:
        V += 0.5 * np.sum(k * np.diff(np.concatenate([[0.0], q[1:]])) ** 2)
    return float(V)


@pytest.mark.parametrize("kernel", ["dense", "fast"])
def test_energy_conserved_without_dissipation(kernel):
    p = CableParams(n_links=N, drag_model="none", joint_dampers=False, platform_damper=False,
                    pin_stiffness=104.7)
    model = CableModel.from_params(p)
    system = CableSystem(model, kernel=kernel)
    y0 = _initial(model, np.random.default_rng(7))
    traj = ScipyIntegrator(system, "DOP853", rtol=1e-12, atol=1e-12).integrate(y0, 0.0, T_END, 0.05)
    n1 = model.ndof
    E = np.array([dynamics.total_energy(model, y[:n1], y[n1:]) for y in traj.y])
    T = np.array([dynamics.kinetic_energy(model, y[:n1], y[n1:]) for y in traj.y])
    # V itself against an independent formula
    for y in traj.y[::40]:
        V = dynamics.potential_energy(model, y[:n1])
        assert abs(V - _independent_potential(p, y[:n1])) <= 1e-9 * max(abs(V), T.max())
    drift = np.max(np.abs(E - E[0])) / T.max()
    print(f"[{kernel}] energy drift {drift:.3e} of peak T = {T.max():.4g} J "
          f"(T exchanged: min {T.min():.4g} J)")
    assert T.max() > 2.0 * T.min() + 1.0  # energy really is exchanged between T and V
    assert drift <= 1e-7


def _forced(t: float) -> Inputs:
    return Inputs(heave_force=2000.0 * np.sin(0.5 * np.pi * t),
                  wave_elevation=0.8 * np.sin(2 * np.pi * t / 7.0))


@pytest.mark.parametrize("drag", ["paper", "morison"])
def test_energy_balance_with_dissipation_and_forcing(drag):
    p = CableParams(n_links=N, drag_model=drag, current_speed=0.3 if drag == "morison" else 0.0,
                    pin_stiffness=104.7, pin_damping=2.8, joint_damping=30.0)
    model = CableModel.from_params(p)
    system = CableSystem(model, _forced, kernel="dense")
    n1 = model.ndof

    def rhs(t, z):
        y = z[:-2]
        q, qd = y[:n1], y[n1:]
        P = dynamics.power(model, q, qd, _forced(t))
        return np.concatenate([system.rhs(t, y), [sum(P.values()),
                                                  sum(abs(v) for v in P.values())]])

    y0 = _initial(model, np.random.default_rng(11))
    ts = np.linspace(0.0, T_END, 41)
    sol = solve_ivp(rhs, (0.0, T_END), np.concatenate([y0, [0.0, 0.0]]), method="DOP853",
                    rtol=1e-12, atol=1e-12, t_eval=ts)
    assert sol.status == 0, sol.message
    E = np.array([dynamics.total_energy(model, z[:n1], z[n1:2 * n1]) for z in sol.y.T])
    W, Wabs = sol.y[-2], sol.y[-1]
    err = np.max(np.abs((E - E[0]) - W))
    scale = np.max(np.abs(W))
    print(f"[{drag}] work of non-conservative forces: final {W[-1]:.6g} J, max |W| {scale:.6g} J, "
          f"gross {Wabs[-1]:.6g} J; max |dE - W| = {err:.3e} J = {err / scale:.3e} of max |W|")
    # all the terms really act
    P0 = dynamics.power(model, y0[:n1], y0[n1:], _forced(0.3))
    assert P0["damping"] < 0 and P0["drag"] != 0 and P0["external"] != 0
    assert scale > 1e3
    assert err <= 1e-5 * scale
