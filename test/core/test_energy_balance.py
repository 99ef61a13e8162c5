"""Energy conservation and energy balance of the dynamics (n = 10, DOP853 reference integrator):
the one home of the energy reference (merged from test_energy and test_verify_energy, issue 10).

References (independent of ``dynamics.total_energy`` / ``dynamics.power``): the energy
E = T + V and the power of the non-conservative forces are computed by ``conftest.RefLine``
straight from the positions/velocities of the platform, link centres and load, the spring
energies on relative joint angles, the Rayleigh dissipation of the dampers and the drag forces
at the link centres. The integrator is scipy's DOP853 at tight tolerance, so any energy error
above the tolerance level is a modelling error of the equations of motion.

Normalisations: conservative drift = max_t |E(t) - E(0)| / max_t T(t) (the peak kinetic energy
does not depend on the potential-energy datum); balance error = max_t |E(t) - E(0) - W(t)| /
max_t |W(t)|, with W(t) = int_0^t P dt integrated together with the state (accumulator).
The package's own energy functions are checked against the reference along the way: T + V up
to the datum, V absolutely (same datum: z = 0 at the surface, springs at rest at zero angle),
and ``dynamics.power`` term by term at random states.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import RefLine
from scipy.integrate import solve_ivp

from cable_sim.core import dynamics
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.core.system import CableSystem
from cable_sim.integrate import ScipyIntegrator

N = 10
HORIZON = 20.0


def initial_state() -> np.ndarray:
    """Bent line, platform 2 m above its spring's rest point, at rest: a large free motion."""
    q0 = np.concatenate([[2.0], np.linspace(1.4, 0.2, N)])
    return np.concatenate([q0, np.zeros(N + 1)])


@pytest.mark.parametrize("kernel", ["dense", "fast"])
def test_conservative_energy_drift(kernel: str) -> None:
    """Drag, dampers and forcing off: |E(t) - E(0)| / max T <= 1e-7 over 20 s (DOP853, tol 1e-12),
    on both kernels, E from the reference; energy really is exchanged between T and V.

    Joint springs, pin spring, heave spring, buoyancy and a 60 kg load stay on.
    """
    p = CableParams(n_links=N, drag_model="none", joint_dampers=False, platform_damper=False,
                    pin_stiffness=50.0)
    model = CableModel.from_params(p)
    ref = RefLine(p)
    integ = ScipyIntegrator(CableSystem(model, kernel=kernel), rtol=1e-12, atol=1e-12)
    tr = integ.integrate(initial_state(), 0.0, HORIZON, 0.02)
    n1 = N + 1
    E = np.array([ref.energy(y[:n1], y[n1:]) for y in tr.y])
    T = np.array([ref.kinetic(y[:n1], y[n1:]) for y in tr.y])
    assert T.max() > 1e4  # the motion is not trivial (peak kinetic energy ~1.2e5 J)
    assert T.max() > 2.0 * T.min() + 1.0  # energy really is exchanged between T and V
    drift = np.max(np.abs(E - E[0])) / T.max()
    print(f"[{kernel}] conservative energy drift / peak T = {drift:.3g} (T_max = {T.max():.6g} J)")
    assert drift <= 1e-7
    # the package's own energy function agrees with the reference up to a constant datum, and
    # its potential energy with the reference's absolutely
    Ec = np.array([dynamics.total_energy(model, y[:n1], y[n1:]) for y in tr.y[::50]])
    assert np.max(np.abs((Ec - Ec[0]) - (E[::50] - E[0]))) <= 1e-10 * T.max()
    for y in tr.y[::40]:
        V = dynamics.potential_energy(model, y[:n1])
        assert abs(V - ref.potential(y[:n1])) <= 1e-9 * max(abs(V), T.max())


@pytest.mark.parametrize("drag", ["paper", "morison"])
def test_energy_balance_with_dissipation_and_forcing(drag: str) -> None:
    """Drag (Morison with a 0.5 m/s current, or paper), joint dampers, heave damper, a 20 kN
    sine heave force and a 1.5 m wave at the platform: E(t) - E(0) = int_0^t P dt to 1e-5 of
    max |W| over 20 s, with the work W integrated as an extra ODE state by DOP853 (tol 1e-11)."""
    p = CableParams(n_links=N, drag_model=drag, current_speed=0.5 if drag == "morison" else 0.0,
                    pin_stiffness=50.0, pin_damping=3.0)
    model = CableModel.from_params(p)
    ref = RefLine(p)
    assert ref.c.all() and ref.cm > 0 and ref.km > 0

    def u(t: float) -> float:
        return 20000.0 * np.sin(0.5 * np.pi * t)

    def eta(t: float) -> float:
        return 1.5 * np.sin(2 * np.pi * t / 7.0)

    system = CableSystem(model, lambda t: Inputs(u(t), eta(t)))
    n1 = N + 1

    def f(t: float, ya: np.ndarray) -> np.ndarray:
        y = ya[:-1]
        return np.concatenate([system.rhs(t, y), [ref.power(y[:n1], y[n1:], u(t), eta(t))]])

    ts = np.linspace(0.0, HORIZON, 401)
    sol = solve_ivp(f, (0.0, HORIZON), np.concatenate([initial_state(), [0.0]]), method="DOP853",
                    rtol=1e-11, atol=1e-11, t_eval=ts)
    assert sol.success
    # all the terms really act (the package's power, term by term, at t = 1 s)
    y1 = sol.y[:-1, 20]
    P1 = dynamics.power(model, y1[:n1], y1[n1:], Inputs(u(1.0), eta(1.0)))
    assert P1["damping"] < 0 and P1["drag"] != 0 and P1["external"] != 0
    E = np.array([ref.energy(y[:n1], y[n1:-1]) for y in sol.y.T])
    W = sol.y[-1]
    scale = np.max(np.abs(W))
    assert scale > 1e4  # the non-conservative work is substantial (~5e4 J)
    err = np.max(np.abs(E - E[0] - W)) / scale
    print(f"{drag}: energy balance error / max|W| = {err:.3g} (max|W| = {scale:.6g} J)")
    assert err <= 1e-5


@pytest.mark.parametrize("drag", ["paper", "morison"])
def test_power_function_matches_reference(drag: str) -> None:
    """``dynamics.power`` (its terms summed) equals the reference power at random states."""
    rng = np.random.default_rng(5)
    p = CableParams(n_links=N, drag_model=drag, current_speed=0.3, pin_damping=2.0)
    model = CableModel.from_params(p)
    ref = RefLine(p)
    for _ in range(5):
        q = np.concatenate([[rng.normal()], rng.uniform(-np.pi, np.pi, N)])
        qd = rng.normal(size=N + 1)
        inp = Inputs(rng.normal() * 1e4, rng.normal())
        P = sum(dynamics.power(model, q, qd, inp).values())
        P_ref = ref.power(q, qd, inp.heave_force, inp.wave_elevation)
        assert P == pytest.approx(P_ref, rel=1e-9)
