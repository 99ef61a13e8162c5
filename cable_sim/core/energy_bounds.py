"""Physical energy bounds of a scene, for detecting a numerical instability from physics.

:func:`available_energy` is the energy a state can turn into motion without input work,
:func:`input_power_bound` an upper bound on the power the inputs can feed in, :func:`energy_floor`
the scene's own energy scale and :func:`kinetic_lower_bound` the part of the kinetic energy the
compiled check compares with the bound. Used by :mod:`cable_sim.integrate.checks`.

Core layer: imports numpy and the compiled kernel only.
"""

from __future__ import annotations

import numpy as np

from cable_sim.core import kernel


def kinetic_lower_bound(model, y: np.ndarray) -> float:
    """``1/2 M zd^2 + sum_i 1/2 (m_i l_i^2 / 12) thd_i^2`` [J]: the platform's and the links'
    rotational kinetic energy, a lower bound of the kinetic energy (what the per-step check of
    :func:`cable_sim.core.kernel.check_packed` compares with the bound)."""
    n1 = model.ndof
    w = np.asarray(y[n1 + 1:], dtype=float)
    return float(0.5 * model.platform_mass * y[n1] ** 2
                 + np.sum(model.mass * model.length ** 2 * w * w) / 24.0)


def available_energy(model, y: np.ndarray) -> float:
    """Energy [J] that can become kinetic without input work: ``E(y) - V_min``.

    ``V_min`` is a lower bound of the potential energy over all configurations: each link
    centre (load) at most its arc length s_i (L) below or above the fairlead, joint springs
    relaxed, and the heave spring plus the line's weight at their minimum
    ``-(g G)^2 / (2 k_m)`` (``G`` the total weight-minus-buoyancy mass; the platform's own
    position when heave is locked). Infinite when the potential is unbounded below (free
    platform with no heave stiffness under a net weight): the check is then off.
    """
    n1 = model.ndof
    q, qd = np.asarray(y[:n1], dtype=float), np.asarray(y[n1:], dtype=float)
    t_kin, v_pot = kernel.energy(model, q, qd)
    g = float(model.gravity)
    s = np.cumsum(model.length) - 0.5 * model.length
    G = g * (float(np.sum(model.weight_mass)) + float(model.load_weight_mass))
    spread = g * (float(np.sum(np.abs(model.weight_mass) * s))
                  + abs(float(model.load_weight_mass)) * float(np.sum(model.length)))
    km = float(model.heave_k)
    if model.heave_locked:
        v_heave = 0.5 * km * q[0] ** 2 + G * q[0]
    elif km > 0:
        v_heave = -G * G / (2.0 * km)
    elif G == 0.0:
        v_heave = 0.0
    else:
        return float("inf")
    return float(t_kin + v_pot - (v_heave - spread))


def energy_floor(model) -> float:
    """The scene's own energy scale [J], added to every energy budget so that a line at rest
    (available energy ~0) is not held to a round-off-deep bound: the line and load moving at
    1 m/s, each link lifted by its own length, each joint spring turned by 1 rad and the heave
    spring stretched by 1 m."""
    g = float(model.gravity)
    lmin = float(np.min(model.length))
    return float(0.5 * (float(np.sum(model.mass)) + float(model.load_mass)) * 1.0
                 + g * (float(np.sum(np.abs(model.weight_mass) * model.length))
                        + abs(float(model.load_weight_mass)) * lmin)
                 + 0.5 * float(np.sum(model.joint_k)) + 0.5 * float(model.heave_k))


def input_power_bound(model, heave_force: float, wave_elevation: float, energy: float) -> float:
    """Upper bound [W] of the power the inputs can feed into the line.

    The platform force ``u + k_m eta`` (wave term when coupled) against the heave damper:
    ``max_v (u v - c_m v^2) = u^2 / (4 c_m)``; without a damper ``|u| sqrt(2 E / M)`` (the
    platform speed bounded by the energy ``E``). A uniform current through Morison drag:
    ``max_w c |w|^2 (|U| - |w|) = (4/27) c |U|^3`` per link. Joint dampers and drag
    otherwise only dissipate.
    """
    p = 0.0
    if not model.heave_locked:
        u = abs(float(heave_force))
        if model.wave_coupling:
            u += abs(float(model.heave_k * wave_elevation))
        if u > 0:
            if model.heave_c > 0:
                p += u * u / (4.0 * float(model.heave_c))
            elif model.platform_mass > 0:
                p += u * np.sqrt(2.0 * max(energy, 0.0) / float(model.platform_mass))
            else:
                return float("inf")
    if model.drag == 2 and model.current:
        c = np.maximum(model.morison_cn, model.morison_ct)
        p += 4.0 / 27.0 * float(np.sum(c)) * abs(float(model.current)) ** 3
    return float(p)
