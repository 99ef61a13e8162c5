"""Issue 11: with the seabed contact in the O(n) operator, the implicit schemes run the mooring
line on its bed at steps where RK4 is unstable, stay accurate and settle on the bed.

mooring_line (n = 40, seabed k_b = 1e5 N/m^2, c_b = 3000 N s/m^2, added mass, wave off) from its
static equilibrium with the buoy kicked to 1 m/s (the heave excites the whole line; laid links
lift off and land again). RK4 at h = 0.15 s blows up (its limit here is 0.11-0.125 s: the
contact's bounce, sqrt(k_b / (m + m_a)) = 28 rad/s with c_b / (m + m_a) = 23 /s). ROS2 and
ROS34PW2 at the same step run 60 s, follow RK4 at h = 0.01 s (the scene's own step; 1.4e-5 m
from RK4 at 0.005 s) within the bounds below (measured: 0.11 / 0.10 m in the first bounce on
the bed, which 0.15 s does not resolve; 0.03 m after 10 s, of a 0.57 m motion), and at the
end the laid part rests on the bed at the static penetration w / k_b (w the submerged weight per
length, from the scene's parameters). Before the contact was in the operator ROS2 failed at
0.1 s and ROS34PW2 at 0.075 s on this run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cable_sim.core import dynamics
from cable_sim.integrate import IntegrationError
from cable_sim.scene.scenes import load_scene
from cable_sim.scene.simulation import Simulation

H_BIG = 0.15
T_END = 60.0
FRAME = 2.5


def _sim(integrator: str, step: float) -> Simulation:
    scene = load_scene("mooring_line", {"wave_source": "none"})
    sim = Simulation(scene, integrator=integrator, step=step)
    assert sim.model.seabed and sim.model.added_mass
    y = sim.y0.copy()
    y[sim.model.ndof] = 1.0  # buoy heave velocity
    sim.y0 = sim.system.project(y)
    sim.reset()
    return sim


def _frames(sim: Simulation) -> np.ndarray:
    m = sim.model
    out = []
    for k in range(1, int(round(T_END / FRAME)) + 1):
        sim.run_until(k * FRAME)
        assert np.all(np.isfinite(sim.y))
        out.append(dynamics.joint_positions(m, sim.y[: m.ndof]))
    return np.array(out)


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    return _frames(_sim("rk4", 0.01))


def test_rk4_is_unstable_at_the_large_step() -> None:
    sim = _sim("rk4", H_BIG)
    with pytest.raises(IntegrationError) as info:
        sim.run_until(T_END)
    print(f"\nrk4 h={H_BIG}: {info.value}")
    assert "instability" in info.value.reason


@pytest.mark.parametrize("integrator", ["rosenbrock2", "ros34pw2"])
def test_implicit_schemes_stable_accurate_and_at_rest_on_the_bed(integrator: str,
                                                                  reference: np.ndarray) -> None:
    sim = _sim(integrator, H_BIG)
    frames = _frames(sim)
    err = np.linalg.norm(frames - reference, axis=-1).max()
    m, p = sim.model, sim.scene.params
    q, qd = sim.y[: m.ndof], sim.y[m.ndof:]
    speed = np.linalg.norm(dynamics.joint_velocities(m, q, qd), axis=1)
    depth = p.seabed_depth - frames[-1][:, 1]
    laid = depth > 0.0
    # static penetration w / k_b, w = (mass per length - rho_w pi d^2 / 4) g
    d = float(np.atleast_1d(p.diameter)[-1])  # uniform chain
    w = (p.mass_per_length - p.water_density * math.pi * d**2 / 4.0) * p.gravity
    rest = w / p.seabed_stiffness
    pen = np.median(depth[laid])
    late = np.linalg.norm(frames - reference, axis=-1)[int(10.0 / FRAME):].max()
    print(f"\n{integrator} h={H_BIG}: max joint position error vs rk4 h=0.01 over {T_END:g} s "
          f"{err:.3g} m (after 10 s {late:.3g} m; the motion is 0.57 m); at the end: "
          f"{laid.sum()} joints in the bed, their max speed {speed[laid].max():.2g} m/s, median "
          f"penetration {1e3 * pen:.2f} mm (w / k_b = {1e3 * rest:.2f} mm); max joint speed "
          f"{speed.max():.2g} m/s (the hanging part's slow swing)")
    # stable is not accurate: the first bounce on the bed (28 rad/s) is not resolved at 0.15 s
    # (0.11 m error at t = 2.5 s; 1 mm at h = 0.05 s), the slower motion after it is
    assert err < 0.25 and late < 0.08
    assert laid.sum() > m.n // 4
    assert speed[laid].max() < 0.01
    assert abs(pen - rest) < 0.05 * rest
