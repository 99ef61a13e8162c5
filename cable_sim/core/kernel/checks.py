"""The integrators' per-step checks, compiled: finite, projection and drift (anchored), slack and
Schur conditioning, kinetic-energy bound, energy jump, runaway oscillation; their status codes.

Core layer, compiled kernel: imports numba, numpy, :mod:`cable_sim.core.kernel.anchor`,
:mod:`cable_sim.core.kernel.energy` and :mod:`cable_sim.core.kernel.links`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from cable_sim.core.kernel.anchor import condition_2x2, project_packed_ws, schur_packed
from cable_sim.core.kernel.energy import energy_terms
from cable_sim.core.kernel.links import link_trig

#: Status codes returned by the compiled steppers and checks.
STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_DRIFT = 2
STATUS_TAUT = 3
STATUS_SINGULAR = 4
STATUS_ILL_CONDITIONED = 5
STATUS_UNSTABLE = 6
STATUS_ENERGY_JUMP = 7
STATUS_OSCILLATION = 8

#: Runaway detector of :func:`check_packed`: a step's velocity increment larger than the
#: previous one by this factor, ...
OSC_GROWTH = 1.5
#: ... this many steps in a row, ...
OSC_STEPS = 3
#: ... each above ``OSC_ACCEL g h / l_min`` (an angular acceleration ten times a link's
#: pendulum scale), is a numerically unstable mode growing geometrically (|R(h lambda)| > 1).
OSC_ACCEL = 10.0
#: 1/24 (the kinetic-energy bound multiplies instead of dividing per link).
_INV24 = 1.0 / 24.0


@nb.njit(cache=True)
def check_packed(
    arr: np.ndarray, par: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray
) -> int:
    """:func:`check_packed_ws` with the links' cos/sin formed here (scratch of its own).

    See :func:`check_packed_ws` for the checks, ``chk`` and ``info``.
    """
    n = arr.shape[1]
    trig = np.empty((2, n))
    if par[10] == 0.0 and chk.shape[0] > 7 and np.isfinite(chk[6]):  # else not read / recomputed
        link_trig(y, trig[0], trig[1])
    return check_packed_ws(arr, par, y, chk, info, trig[0], trig[1])


@nb.njit(cache=True, error_model="numpy")
def check_packed_ws(
    arr: np.ndarray, par: np.ndarray, y: np.ndarray, chk: np.ndarray, info: np.ndarray,
    cth: np.ndarray, sth: np.ndarray,
) -> int:
    """The integrator's per-step check, compiled: finite, project (anchored), drift, slack,
    Schur conditioning. ``chk = [max_drift, taut_slack, projection tol, max Schur condition,
    slack below which the Schur condition is checked]``. Modifies ``y`` (projection); on failure
    writes the offending value to ``info[2]`` and returns a status code.

    ``chk[5]`` (when present) is a kinetic-energy bound [J]: the lower bound of the kinetic
    energy ``1/2 M zd^2 + sum 1/2 (m_i l_i^2 / 12) thd_i^2`` (platform + link rotation) above it
    returns ``STATUS_UNSTABLE`` (numerical instability), checked last so that a taut anchored
    line still reports its snap load. O(n) multiply-adds.

    ``chk[6]`` (when present and finite) is the mechanical energy of the previous accepted
    state [J] and ``chk[7]`` the largest increase allowed over one step [J]: a larger increase
    returns ``STATUS_ENERGY_JUMP`` (energy increase in ``info[2]``); on success ``chk[6]``
    becomes the new state's energy. One O(n) energy evaluation.

    ``chk[8:]`` (when ``chk`` has ``11 + 2 (n+1)`` entries) is the runaway detector's memory:
    ``[count, valid, floor, previous qd (n+1), previous qd increment (n+1)]``. A velocity
    increment ``d_k`` with ``|d_k| > OSC_GROWTH |d_(k-1)|`` and ``|d_k| > floor`` for
    ``OSC_STEPS`` steps in a row returns ``STATUS_OSCILLATION`` (growth factor in ``info[2]``):
    a mode growing geometrically at every step is the signature of a scheme beyond its
    stability limit (RK4's R(z) > 1 for real z < -2.79, sign-alternating for explicit Euler). O(n).

    ``cth``, ``sth`` (length n) hold the cos/sin of the links' angles ``y[1:n+1]`` as given
    (:func:`cable_sim.core.kernel.links.link_trig`; the energy check uses them); a projection
    (anchored end) recomputes them, so that on return they are those of the final ``y``.
    """
    for v in y:
        if not np.isfinite(v):
            return STATUS_NONFINITE
    status = _anchor_checks(arr, par, y, chk, info, cth, sth)  # (a projection updates cth, sth)
    if status != STATUS_OK:
        return status
    status = _energy_checks(arr, par, y, chk, info, cth, sth)
    if status != STATUS_OK:
        return status
    return oscillation_packed(y, chk, info)


@nb.njit(cache=True)
def oscillation_packed(y: np.ndarray, chk: np.ndarray, info: np.ndarray) -> int:
    """The oscillation detector of :func:`check_packed` on its memory ``chk[8:]`` (no-op
    unless ``chk`` has ``11 + 2 (n+1)`` entries); updates the memory when the state passes;
    on failure the growth factor is in ``info[2]``."""
    n1 = y.shape[0] // 2
    if chk.shape[0] != 11 + 2 * n1:
        return STATUS_OK
    o = 11
    if chk[9] >= 1.0:
        dd = 0.0
        pp = 0.0
        for j in range(n1):
            d = y[n1 + j] - chk[o + j]
            p = chk[o + n1 + j]
            dd += d * d
            pp += p * p
        if chk[9] >= 2.0 and dd > OSC_GROWTH * OSC_GROWTH * pp and dd > chk[10] * chk[10]:
            if chk[8] + 1.0 >= OSC_STEPS:
                info[2] = np.sqrt(dd / pp)
                return STATUS_OSCILLATION
            chk[8] += 1.0
        else:
            chk[8] = 0.0
        for j in range(n1):
            chk[o + n1 + j] = y[n1 + j] - chk[o + j]
        chk[9] = 2.0
    else:
        chk[9] = 1.0
    for j in range(n1):
        chk[o + j] = y[n1 + j]
    return STATUS_OK


@nb.njit(cache=True, inline="always")
def _anchor_checks(arr: np.ndarray, par: np.ndarray, y: np.ndarray, chk: np.ndarray,
                   info: np.ndarray, cth: np.ndarray, sth: np.ndarray) -> int:
    """Anchored end: project (finite after; the links' cos/sin of the projected state into
    ``cth``, ``sth``), drift; a nearly taut line: slack, Schur condition."""
    if par[10] != 0.0:
        drift = project_packed_ws(arr, par, y, chk[2], cth, sth)
        for v in y:
            if not np.isfinite(v):
                return STATUS_NONFINITE
        if drift > chk[0]:
            info[2] = drift
            return STATUS_DRIFT
    if par[15] != 0.0:
        slack = 1.0 - np.hypot(par[11], y[0] - par[12]) / par[16]
        if slack < chk[1]:
            info[2] = slack
            return STATUS_TAUT
        if slack < chk[4]:
            n1 = y.shape[0] // 2
            s = schur_packed(arr, par, y[:n1])
            cond = condition_2x2(s[0, 0], s[0, 1], s[1, 0], s[1, 1])
            if cond > chk[3]:
                info[2] = cond
                return STATUS_ILL_CONDITIONED
    return STATUS_OK


@nb.njit(cache=True, inline="always")
def _energy_checks(arr: np.ndarray, par: np.ndarray, y: np.ndarray, chk: np.ndarray,
                   info: np.ndarray, cth: np.ndarray, sth: np.ndarray) -> int:
    """Kinetic-energy lower bound against ``chk[5]``; energy increase over a step against ``chk[7]``."""
    n1 = y.shape[0] // 2
    if chk.shape[0] > 5:
        l = arr[0]
        m = arr[1]
        tlb = 0.5 * par[4] * y[n1] * y[n1]
        for i in range(n1 - 1):
            w = y[n1 + 1 + i]
            tlb += m[i] * l[i] * l[i] * w * w * _INV24
        if tlb > chk[5]:
            info[2] = tlb
            return STATUS_UNSTABLE
    if chk.shape[0] > 7 and np.isfinite(chk[6]):
        t_kin, v_pot = energy_terms(arr[0], arr[1], arr[2], arr[3], par[2], par[3], par[4],
                                    par[5], par[9], y[:n1], y[n1:], par[17] != 0.0, par[18],
                                    arr[8], cth, sth)
        e_new = t_kin + v_pot
        if e_new - chk[6] > chk[7]:
            info[2] = e_new - chk[6]
            return STATUS_ENERGY_JUMP
        chk[6] = e_new
    return STATUS_OK
