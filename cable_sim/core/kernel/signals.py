"""Compiled evaluation of the built-in input signals and of a system's input program.

A built-in signal (:mod:`cable_sim.core.inputs`) packs into a small float array
(``signal.packed()``), its *packed form*::

    [kind, ramp, m, offset, a_1, b_1, c_1, ..., a_m, b_m, c_m]

=========  =======================================================================  ==========
``kind``   value at t (``r(t)``: the half-cosine start ramp over ``ramp`` seconds)  Python
=========  =======================================================================  ==========
0          ``offset``                                                               Constant
1          ``(r(t) a_1) sin(2 pi t / b_1 + c_1)`` (amplitude, period, phase)        Sine
2          ``r(t) sum_i a_i cos(b_i t + c_i)`` (amplitude, omega, phase)            Jonswap
=========  =======================================================================  ==========

The operations are those of the Python signals, in the same order (the JONSWAP sum is numpy's
pairwise summation, :func:`pairwise_sum`), so a compiled value equals the Python one up to the
last bit of the libm sin/cos the two call (identical on the machines tested).

An *input program* (:func:`pack_program`) is the system's whole input,
``u(t) = heave(t) + held_u`` and ``eta(t) = wave(t) + held_eta``, as one array::

    [held_u, held_eta, start of the wave signal, <heave signal>, <wave signal>]

The held values (the ROS node's zero-order hold) live in the array, so the owner changes them
in place (:data:`HELD_U`, :data:`HELD_ETA`). :func:`sample_program` fills the input arrays a
compiled stepper consumes, at ``t0 + k h + offset h`` (the times the Python path samples), and
returns their largest magnitudes (for the energy budget of the step checks).

Core layer: numba and numpy only.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Signal kinds of the packed form.
CONSTANT, SINE, COSINE_SUM = 0, 1, 2
#: Index of the first term (a_1) in a packed signal.
TERMS = 4
#: Indices of the held values and of the start of the wave signal in an input program.
HELD_U, HELD_ETA, WAVE_START = 0, 1, 2
#: Index of the heave signal in an input program.
HEAVE_START = 3

_TWO_PI = 2 * np.pi  # the Python signals' ``2 * np.pi * t``: (2 pi) t, exact doubling
_PI = np.pi
#: numpy's pairwise-summation block (``PW_BLOCKSIZE`` in numpy's loops_utils).
_PW_BLOCK = 128


def pack_signal(kind: int, ramp: float, offset: float, terms: np.ndarray | None = None) -> np.ndarray:
    """The packed form of a signal (see the module docstring); ``terms`` shape (m, 3)."""
    t = np.zeros((0, 3)) if terms is None else np.asarray(terms, dtype=float).reshape(-1, 3)
    return np.concatenate([[float(kind), float(ramp), float(t.shape[0]), float(offset)], t.ravel()])


def pack_program(heave: np.ndarray, wave: np.ndarray, held_u: float = 0.0,
                 held_eta: float = 0.0) -> np.ndarray:
    """The input program of a system from the packed heave-force and wave signals."""
    head = np.array([held_u, held_eta, HEAVE_START + heave.shape[0]], dtype=float)
    return np.concatenate([head, heave, wave])


def signal_bound(sig: np.ndarray) -> float:
    """An upper bound of ``|signal(t)|`` over all t: ``|offset| + sum |a_i|``."""
    m = int(sig[2])
    return abs(float(sig[3])) + float(np.abs(sig[TERMS:TERMS + 3 * m:3]).sum())


@nb.njit(cache=True, inline="always")
def _ramp(t: float, ramp: float) -> float:
    """As :func:`cable_sim.core.inputs._ramp`."""
    if ramp <= 0.0 or t >= ramp:
        return 1.0
    if t <= 0.0:
        return 0.0
    return 0.5 * (1.0 - math.cos(_PI * t / ramp))


@nb.njit(cache=True, inline="always")
def _block_sum(x: np.ndarray, lo: int, n: int) -> float:
    """numpy's pairwise sum of ``x[lo:lo + n]`` for ``n <= 128``: a plain loop below 8 terms,
    else eight interleaved partial sums added as a tree, then the remaining ``n % 8`` terms."""
    if n < 8:
        s = 0.0
        for i in range(n):
            s += x[lo + i]
        return s
    r0 = x[lo]
    r1 = x[lo + 1]
    r2 = x[lo + 2]
    r3 = x[lo + 3]
    r4 = x[lo + 4]
    r5 = x[lo + 5]
    r6 = x[lo + 6]
    r7 = x[lo + 7]
    i = 8
    while i < n - n % 8:
        r0 += x[lo + i]
        r1 += x[lo + i + 1]
        r2 += x[lo + i + 2]
        r3 += x[lo + i + 3]
        r4 += x[lo + i + 4]
        r5 += x[lo + i + 5]
        r6 += x[lo + i + 6]
        r7 += x[lo + i + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        s += x[lo + i]
        i += 1
    return s


@nb.njit(cache=True)
def pairwise_sum(x: np.ndarray, lo: int, n: int) -> float:
    """``x[lo:lo + n].sum()`` with numpy's pairwise summation (the same additions, so the same
    bits): blocks of at most 128 terms (:func:`_block_sum`); a longer range is split in two
    halves, the first a multiple of 8 long, and their sums added. Iterative (an explicit stack):
    numba's disk cache does not load self-recursive functions reliably."""
    if n <= _PW_BLOCK:
        return _block_sum(x, lo, n)
    cap = 4 * 64
    seg_lo = np.empty(cap, np.int64)
    seg_n = np.empty(cap, np.int64)
    seg_join = np.empty(cap, np.bool_)
    vals = np.empty(cap)
    sp = 1
    seg_lo[0] = lo
    seg_n[0] = n
    seg_join[0] = False
    vp = 0
    while sp > 0:
        sp -= 1
        sl = seg_lo[sp]
        sn = seg_n[sp]
        if seg_join[sp]:  # both halves summed: add them (a + b == b + a exactly)
            vals[vp - 2] = vals[vp - 2] + vals[vp - 1]
            vp -= 1
        elif sn <= _PW_BLOCK:
            vals[vp] = _block_sum(x, sl, sn)
            vp += 1
        else:
            n2 = sn // 2
            n2 -= n2 % 8
            seg_lo[sp], seg_n[sp], seg_join[sp] = sl, sn, True
            seg_lo[sp + 1], seg_n[sp + 1], seg_join[sp + 1] = sl + n2, sn - n2, False
            seg_lo[sp + 2], seg_n[sp + 2], seg_join[sp + 2] = sl, n2, False
            sp += 3
    return vals[0]


@nb.njit(cache=True)
def signal_value(sig: np.ndarray, start: int, t: float, work: np.ndarray) -> float:
    """Value at time t of the packed signal ``sig[start:]``; ``work``: scratch of at least m
    floats (the terms of a cosine sum, summed pairwise as numpy does)."""
    kind = int(sig[start])
    if kind == CONSTANT:
        return sig[start + 3]
    r = _ramp(t, sig[start + 1])
    j = start + TERMS
    if kind == SINE:
        return r * sig[j] * math.sin(_TWO_PI * t / sig[j + 1] + sig[j + 2])
    m = int(sig[start + 2])
    for i in range(m):
        work[i] = sig[j] * math.cos(sig[j + 1] * t + sig[j + 2])
        j += 3
    return r * (0.0 + pairwise_sum(work, 0, m))


@nb.njit(cache=True)
def program_inputs(prog: np.ndarray, t: float, work: np.ndarray) -> tuple[float, float]:
    """``(u(t), eta(t))`` of an input program: built-in signal plus held value each."""
    u = signal_value(prog, HEAVE_START, t, work) + prog[HELD_U]
    eta = signal_value(prog, int(prog[WAVE_START]), t, work) + prog[HELD_ETA]
    return u, eta


@nb.njit(cache=True)
def sample_program(prog: np.ndarray, t0: float, h: float, offsets: np.ndarray, u: np.ndarray,
                   eta: np.ndarray) -> tuple[float, float]:
    """Fill ``u[k, i], eta[k, i]`` with the inputs at ``(t0 + k h) + offsets[i] h`` for
    ``k < u.shape[0]`` (the times and roundings of the Python path) and return
    ``(max |u|, max |eta|)``."""
    nw = int(prog.shape[0])
    work = np.empty(nw)
    oh = np.empty(offsets.shape[0])
    for i in range(offsets.shape[0]):
        oh[i] = offsets[i] * h
    umax = 0.0
    emax = 0.0
    for k in range(u.shape[0]):
        tk = t0 + k * h
        for i in range(oh.shape[0]):
            a, b = program_inputs(prog, tk + oh[i], work)
            u[k, i] = a
            eta[k, i] = b
            if abs(a) > umax or a != a:
                umax = abs(a)
            if abs(b) > emax or b != b:
                emax = abs(b)
    return umax, emax
