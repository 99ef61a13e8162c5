"""Changes of frame of a link's 2x2 articulated inertia (planar chain, ``MODEL.md``).

A symmetric 2x2 inertia is kept in a link's own frame (``t = (cos, sin)`` normal, ``e = (sin,
-cos)`` axis) by the inward sweep (:mod:`cable_sim.core.kernel.sweeps`); these turn a world-frame
inertia into a link frame, a link-frame one back to the world frame or into the parent link's
frame, and give the relative angle's cos/sin. Compiled with numba (``cache=True``), inlined.

Core layer, compiled kernel: imports numba.
"""

from __future__ import annotations

import numba as nb

# ---- 2x2 articulated inertia in the link frame -------------------------------------------------


@nb.njit(cache=True, inline="always")
def link_frame(axx: float, axz: float, azz: float, c: float, s: float) -> tuple[float, float, float]:
    """``t^T A t, t^T A e, e^T A e`` of a symmetric world-frame A (xx, xz, zz).

    The rotation of :func:`to_parent_frame` with the world frame (x, -z) as the "child"
    (``x^T A (-z) = -axz``): ``t = c x - s (-z)``, ``e = s x + c (-z)``, i.e. relative cos/sin
    ``c, -s``; the sign changes are exact, so this is the same arithmetic. An isotropic A (the
    load, ``m_c I``) gives ``t^T A e = 0`` exactly.
    """
    return to_parent_frame(axx, -axz, azz, c, -s)


@nb.njit(cache=True, inline="always")
def to_world(a_tt: float, a_te: float, a_ee: float, c: float, s: float) -> tuple[float, float, float]:
    """World-frame (xx, xz, zz) of ``a_tt t t^T + a_te (t e^T + e t^T) + a_ee e e^T``.

    The rotation of :func:`to_parent_frame` with the link as the "child" and the world frame
    (x, -z) as the "parent": ``x = c t + s e`` and ``-z = -s t + c e`` for the link's
    ``t = (c, s)``, ``e = (s, -c)``; the world's xz entry is minus that frame's cross term.
    """
    axx, neg_axz, azz = to_parent_frame(a_tt, a_te, a_ee, c, s)
    return axx, -neg_axz, azz


@nb.njit(cache=True, inline="always")
def to_parent_frame(p: float, r: float, u: float, cr: float, sr: float) -> tuple[float, float, float]:
    """``t^T A t, t^T A e, e^T A e`` in a link's frame (t, e) of a symmetric A given in its
    child's frame (t', e') as ``p = t'^T A t', r = t'^T A e', u = e'^T A e'``.

    ``cr = t.t' = e.e'`` and ``sr = t.e' = -e.t'`` are the cos/sin of the child's angle minus
    the link's (:func:`relative_trig`): ``t = cr t' + sr e'``, ``e = -sr t' + cr e'``. An
    isotropic A (``p = u``, ``r = 0``) gives ``t^T A e = 0`` exactly; A enters each product
    once (the trig products do not depend on the recursion).
    """
    cc = cr * cr
    ss = sr * sr
    cs = cr * sr
    x = p * cc + r * (2.0 * cs) + u * ss
    y = (u - p) * cs + r * (cc - ss)
    z = p * ss - r * (2.0 * cs) + u * cc
    return x, y, z


@nb.njit(cache=True, inline="always")
def relative_trig(c: float, s: float, cc: float, sc: float) -> tuple[float, float]:
    """cos and sin of a child link's angle minus its parent's (child ``cc, sc``, parent
    ``c, s``)."""
    return c * cc + s * sc, c * sc - s * cc
