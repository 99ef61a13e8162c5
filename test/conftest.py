"""Independent reference helpers for the verification suite (issue #2).

Everything here is written from MODEL.md and the :class:`~cable_sim.core.params.CableParams` fields
alone: no function of ``cable_sim.core.model`` / ``cable_sim.core.dynamics`` is called, so the tests that
use these helpers compare the implementation with a second, separately written computation.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))


class RefLine:
    """Per-link physical constants of a line, from the parameters only (MODEL.md "Masses").

    Attributes: ``l`` link lengths, ``m`` link masses, ``mw`` reduced (wet) masses, ``mc`` and
    ``mcw`` the terminal mass and its reduced mass, ``M`` the platform mass, ``g`` gravity,
    ``k``/``c`` joint constants k_1..k_n / c_1..c_n (index 0: fairlead pin), ``km``/``cm`` heave
    spring and damper.
    """

    def __init__(self, p) -> None:
        n = p.n_links
        self.n = n
        if p.link_lengths is not None:
            self.l = np.array([float(v) for v in p.link_lengths])
        else:
            self.l = np.full(n, p.total_length / n)
        d = np.broadcast_to(np.asarray(p.diameter, dtype=float), (n,))
        self.d = np.array(d)
        area = math.pi * self.d**2 / 4.0
        if p.mass_per_length is not None:
            self.m = p.mass_per_length * self.l
        else:
            self.m = np.broadcast_to(np.asarray(p.line_density, dtype=float), (n,)) * area * self.l
        self.mw = self.m - p.water_density * area * self.l if p.buoyancy else self.m.copy()
        if p.end_condition == "free":
            self.mc = p.load_mass
            self.mcw = p.load_mass - (p.water_density * p.load_volume if p.buoyancy else 0.0)
        elif p.end_condition == "paper_anchor":
            self.mc, self.mcw = p.paper_anchor_mass, 0.0
        else:
            self.mc, self.mcw = 0.0, 0.0
        self.M = p.platform_mass
        self.g = p.gravity
        self.rho_w = p.water_density
        k = np.zeros(n)
        c = np.zeros(n)
        for i in range(n):
            if i == 0:
                k[i], c[i] = p.pin_stiffness, p.pin_damping
            elif p.stiffness_mode == "per_joint":
                k[i], c[i] = p.joint_stiffness, p.joint_damping
            else:
                lbar = 0.5 * (self.l[i - 1] + self.l[i])
                k[i], c[i] = p.bending_stiffness / lbar, p.bending_damping / lbar
        self.k = k if p.joint_springs else np.zeros(n)
        self.c = c if p.joint_dampers else np.zeros(n)
        self.km = p.heave_stiffness if p.platform_spring else 0.0
        self.cm = p.heave_damping if p.platform_damper else 0.0
        self.wave = p.wave_coupling
        self.drag = p.drag_model
        self.gamma = p.paper_drag_gamma
        self.cn, self.ct, self.U = p.drag_cn, p.drag_ct, p.current_speed
        # seabed (issue 11): flat floor at z_b, elastic energy int 1/2 k_b delta^2 ds
        self.zb = None
        if getattr(p, "seabed", False):
            self.zb = p.anchor_z if p.seabed_depth is None else float(p.seabed_depth)
        self.kb = float(getattr(p, "seabed_stiffness", 0.0))

    def _bed_intervals(self, q: np.ndarray):
        """Per link: (i, a, b, d0, d1) with delta(s) = d0 + d1 s > 0 on [a, b] (closed forms)."""
        out = []
        if self.zb is None:
            return out
        p = self.joints(q)
        for i in range(self.n):
            d0, d1, l = self.zb - p[i, 1], math.cos(q[1 + i]), self.l[i]
            a, b = 0.0, l
            if d1 > 0:
                a = min(max(0.0, -d0 / d1), l)
            elif d1 < 0:
                b = max(min(l, -d0 / d1), 0.0)
            elif d0 <= 0:
                continue
            if b > a and max(d0 + d1 * a, d0 + d1 * b) > 0:
                out.append((i, a, b, d0, d1))
        return out

    # ---- kinematics (explicit loops: deliberately unlike the vectorised implementation) -----
    def joints(self, q: np.ndarray) -> np.ndarray:
        """Joint points p_0..p_n, shape (n+1, 2)."""
        p = np.zeros((self.n + 1, 2))
        x, z = 0.0, q[0]
        p[0] = (x, z)
        for i in range(self.n):
            x += self.l[i] * math.sin(q[1 + i])
            z -= self.l[i] * math.cos(q[1 + i])
            p[i + 1] = (x, z)
        return p

    def centre_jacobians(self, q: np.ndarray) -> np.ndarray:
        """J[i] = d c_i / d q, shape (n, 2, n+1)."""
        n = self.n
        J = np.zeros((n, 2, n + 1))
        for i in range(n):
            J[i, 1, 0] = 1.0
            for j in range(i + 1):
                f = 0.5 if j == i else 1.0
                J[i, 0, 1 + j] = f * self.l[j] * math.cos(q[1 + j])
                J[i, 1, 1 + j] = f * self.l[j] * math.sin(q[1 + j])
        return J

    def end_jacobian(self, q: np.ndarray) -> np.ndarray:
        """d p_n / d q, shape (2, n+1)."""
        J = np.zeros((2, self.n + 1))
        J[1, 0] = 1.0
        J[0, 1:] = self.l * np.cos(q[1:])
        J[1, 1:] = self.l * np.sin(q[1:])
        return J

    # ---- energies -------------------------------------------------------------------------
    def kinetic(self, q: np.ndarray, qd: np.ndarray) -> float:
        """T from the velocities of the platform, each link centre (+ spin) and the load."""
        J = self.centre_jacobians(q)
        T = 0.5 * self.M * qd[0] ** 2
        for i in range(self.n):
            v = J[i] @ qd
            T += 0.5 * self.m[i] * (v @ v) + 0.5 * (self.m[i] * self.l[i] ** 2 / 12.0) * qd[1 + i] ** 2
        ve = self.end_jacobian(q) @ qd
        T += 0.5 * self.mc * (ve @ ve)
        return float(T)

    def potential(self, q: np.ndarray) -> float:
        """V: wet weight at the centres and the load, heave spring, joint springs (relative angles)."""
        p = self.joints(q)
        V = 0.0
        for i in range(self.n):
            V += self.mw[i] * self.g * 0.5 * (p[i, 1] + p[i + 1, 1])
        V += self.mcw * self.g * p[-1, 1]
        V += 0.5 * self.km * q[0] ** 2
        prev = 0.0
        for i in range(self.n):
            V += 0.5 * self.k[i] * (q[1 + i] - prev) ** 2
            prev = q[1 + i]
        for _i, a, b, d0, d1 in self._bed_intervals(q):  # int 1/2 k (d0 + d1 s)^2 ds
            V += 0.5 * self.kb * (d0 * d0 * (b - a) + d0 * d1 * (b * b - a * a)
                                  + d1 * d1 * (b**3 - a**3) / 3.0)
        return float(V)

    def energy(self, q: np.ndarray, qd: np.ndarray) -> float:
        """E = T + V."""
        return self.kinetic(q, qd) + self.potential(q)

    def potential_gradient(self, q: np.ndarray) -> np.ndarray:
        """dV/dq: weights mapped by the centre/end Jacobians, plus the spring gradients."""
        J = self.centre_jacobians(q)
        gr = np.zeros(self.n + 1)
        for i in range(self.n):
            gr += self.mw[i] * self.g * J[i, 1]
        gr += self.mcw * self.g * self.end_jacobian(q)[1]
        gr[0] += self.km * q[0]
        phi = np.diff(np.concatenate([[0.0], q[1:]]))  # relative joint angles
        tau = self.k * phi
        gr[1:] += tau
        gr[1:-1] -= tau[1:]
        # seabed: dV/dq = -int k delta dz/dq ds, dz/dq = (1, l_j sin th_j (j < i), s sin th_i)
        for i, a, b, d0, d1 in self._bed_intervals(q):
            f0 = self.kb * (d0 * (b - a) + d1 * (b * b - a * a) / 2.0)  # int k delta
            f1 = self.kb * (d0 * (b * b - a * a) / 2.0 + d1 * (b**3 - a**3) / 3.0)  # int k delta s
            gr[0] -= f0
            for j in range(i):
                gr[1 + j] -= f0 * self.l[j] * math.sin(q[1 + j])
            gr[1 + i] -= f1 * math.sin(q[1 + i])
        return gr

    # ---- non-conservative forces ----------------------------------------------------------
    def morison_forces(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Morison force at each link centre (MODEL.md), shape (n, 2)."""
        J = self.centre_jacobians(q)
        F = np.zeros((self.n, 2))
        for i in range(self.n):
            v = J[i] @ qd - np.array([self.U, 0.0])
            e = np.array([math.sin(q[1 + i]), -math.cos(q[1 + i])])
            vt = (v @ e) * e
            vn = v - vt
            F[i] = -0.5 * self.rho_w * self.d[i] * self.l[i] * (
                self.cn * np.linalg.norm(vn) * vn + math.pi * self.ct * np.linalg.norm(vt) * vt
            )
        return F

    def drag_generalised(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Generalised drag force: paper formula, or Jacobian-transpose of the Morison forces."""
        Q = np.zeros(self.n + 1)
        if self.drag == "paper":
            w = qd[1:]
            Q[1:] = -self.gamma * self.l**2 / 4.0 * w * np.abs(w)
        elif self.drag == "morison":
            J = self.centre_jacobians(q)
            F = self.morison_forces(q, qd)
            for i in range(self.n):
                Q += J[i].T @ F[i]
        return Q

    def power(self, q: np.ndarray, qd: np.ndarray, u: float, eta: float) -> float:
        """dE/dt: heave force and wave-spring term, dampers (Rayleigh), drag (Q_drag . qd)."""
        P = (u + (self.km * eta if self.wave else 0.0)) * qd[0] - self.cm * qd[0] ** 2
        prev = 0.0
        for i in range(self.n):
            P -= self.c[i] * (qd[1 + i] - prev) ** 2
            prev = qd[1 + i]
        return float(P + self.drag_generalised(q, qd) @ qd)


def rk4_step(f, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One classical RK4 step, written here so a test can run without the package's projection."""
    k1 = f(t, y)
    k2 = f(t + h / 2, y + h / 2 * k1)
    k3 = f(t + h / 2, y + h / 2 * k2)
    k4 = f(t + h, y + h * k3)
    return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


@pytest.fixture(autouse=True)
def _reap_test_processes():
    """After every test (passed, failed or timed out), kill and reap the processes it started
    through ``ros_util.popen`` / ``start_node`` (fixtures of a wider scope set up before this
    one keep theirs), so no test leaves a process running."""
    import ros_util

    first = ros_util.started()
    yield
    ros_util.reap_all(since=first)


@pytest.fixture(autouse=True, scope="session")
def _reap_session_processes():
    """At the end of the session, kill and reap every process any test or fixture started."""
    yield
    import ros_util

    ros_util.reap_all()
