"""The model as plain arrays for the compiled kernels (numba cannot take the dataclass).

Two forms, each cached per model object: :func:`pack`, a tuple of the 32 arrays and scalars
(the energy and joint-force kernels take them), and :func:`pack_arrays`, the same as two arrays
(``arr`` per link, ``par`` scalars) for the forward dynamics and the compiled steppers, so that
calling one costs a handful of argument conversions instead of ~30.

Core layer: imports numpy and :mod:`cable_sim.core.model` (no numba at import; the inward
sweep's per-link constants and the Woodbury choice are formed by
:mod:`cable_sim.core.kernel.sweeps` and :mod:`cable_sim.core.kernel.links`, imported when a
model is first packed).
"""

from __future__ import annotations

import weakref

import numpy as np

from cable_sim.core.model import CableModel

#: Rows of the per-link array returned by :func:`pack_arrays`.
ARR_ROWS = 21
#: First of its rows holding :func:`link_constants` (7 rows).
ARR_MK = 14

_PACK_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_ARRAYS_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _arr(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def vec(x: np.ndarray, size: int, name: str) -> np.ndarray:
    """``x`` as a contiguous float64 vector of length ``size`` (ValueError naming ``name``)."""
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.shape != (size,):
        raise ValueError(f"{name} has shape {a.shape}; expected ({size},)")
    return a


def link_constants(l: np.ndarray, mn: np.ndarray, me: np.ndarray) -> np.ndarray:
    """Per-link constants of the compiled inward sweep, rows mn/3, mn/4, mn/6, mn/2, 1/l^2,
    me/2, l^2 (``mn``, ``me``: the link masses along the normal and the axis), formed once per
    model by :func:`cable_sim.core.kernel.sweeps.fill_link_constants` (the one implementation)."""
    from cable_sim.core.kernel.sweeps import MK_ROWS, fill_link_constants

    l = np.ascontiguousarray(l, dtype=np.float64)
    mk = np.empty((MK_ROWS, l.shape[0]))
    fill_link_constants(l, np.ascontiguousarray(mn, dtype=np.float64),
                        np.ascontiguousarray(me, dtype=np.float64), mk)
    return mk


def pack(model: CableModel) -> tuple:
    """Plain-typed model data for the kernels (cached per model object)."""
    try:
        return _PACK_CACHE[model]
    except (KeyError, TypeError):
        pass
    fd = (
        _arr(model.length),
        _arr(model.mass),
        _arr(model.weight_mass),
        _arr(model.joint_k),
        _arr(model.joint_c),
        _arr(model.drag_gamma_l2),
        _arr(model.morison_cn),
        _arr(model.morison_ct),
        float(model.current),
        int(model.drag),
        float(model.load_mass),
        float(model.load_weight_mass),
        float(model.platform_mass),
        float(model.heave_k),
        float(model.heave_c),
        bool(model.heave_locked),
        bool(model.wave_coupling),
        float(model.gravity),
        bool(model.constrained),
        float(model.anchor[0]),
        float(model.anchor[1]),
        float(model.baumgarte_alpha),
        float(model.baumgarte_beta),
        # round-2 terms (MODEL.md): seabed on, its z, per-link k_b, c_b, mu_a, mu_t, v_c; the
        # link masses seen along the normal and along the axis (m + m_an l, m + m_at l: equal to
        # m without added mass)
        bool(model.seabed),
        float(model.seabed_z) if model.seabed else 0.0,
        _arr(model.seabed_k),
        _arr(model.seabed_c),
        _arr(model.friction_axial),
        _arr(model.friction_transverse),
        float(model.friction_speed),
        _arr(model.mass + model.added_mass_normal * model.length),
        _arr(model.mass + model.added_mass_axial * model.length),
    )
    try:
        _PACK_CACHE[model] = fd
    except TypeError:
        pass
    return fd


def pack_arrays(model: CableModel) -> tuple[np.ndarray, np.ndarray]:
    """The model as two arrays for the compiled steppers (cached per model object).

    Returns
    -------
    arr : ndarray (21, n)
        Rows: l, m, m~, k, c, gamma l^2/4, Morison c_n, Morison c_t, seabed k_b, c_b, mu_a,
        mu_t, normal mass m + m_an l, axial mass m + m_at l, then the inward sweep's per-link
        constants from row :data:`ARR_MK` (:func:`link_constants`: mn/3, mn/4, mn/6, mn/2,
        1/l^2, me/2, l^2).
    par : ndarray (21,)
        current, drag code, m_c, m~_c, M, k_m, c_m, heave_locked, wave_coupling, g,
        constrained, anchor x, anchor z, Baumgarte alpha, beta, end code, total length,
        seabed on, seabed z, friction speed v_c, and whether the load enters the forward
        dynamics by Woodbury (:func:`cable_sim.core.kernel.links.woodbury_load`, decided once
        per model here rather than per call).
    """
    try:
        return _ARRAYS_CACHE[model]
    except (KeyError, TypeError):
        pass
    from cable_sim.core.kernel.links import woodbury_load

    p = pack(model)
    heavy = woodbury_load(p[1], p[10], p[18], p[15])
    base = np.stack(p[:8] + p[25:29] + p[30:32])
    arr = np.ascontiguousarray(np.concatenate([base, link_constants(p[0], p[30], p[31])]),
                               dtype=np.float64)
    par = np.array(
        [p[8], p[9], p[10], p[11], p[12], p[13], p[14], float(p[15]), float(p[16]), p[17],
         float(p[18]), p[19], p[20], p[21], p[22], float(model.end), float(np.sum(model.length)),
         float(p[23]), p[24], p[29], float(heavy)],
        dtype=np.float64,
    )
    try:
        _ARRAYS_CACHE[model] = (arr, par)
    except TypeError:
        pass
    return arr, par
