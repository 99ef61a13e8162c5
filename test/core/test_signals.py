"""The compiled input signals (core/kernel/signals.py) against the signals' own formulas.

Expected values are written here from the defining formulas with numpy (half-cosine ramp,
``A sin(2 pi t / T + phi)``, ``sum_i a_i cos(w_i t + p_i)``), not taken from the Python signal
classes, and compared to 1e-12 of the signal's amplitude scale (round-off only: the compiled
arithmetic follows the Python one but libm may differ by an ulp between machines).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cable_sim.core.inputs import Constant, Jonswap, Sine, make_signal
from cable_sim.core.kernel.signals import (
    HELD_ETA,
    HELD_U,
    pack_program,
    pairwise_sum,
    program_inputs,
    sample_program,
    signal_bound,
    signal_value,
)

REL = 1e-12


def _ramp(t: np.ndarray, tr: float) -> np.ndarray:
    if tr <= 0:
        return np.ones_like(t)
    return np.where(t <= 0, 0.0, np.where(t >= tr, 1.0, 0.5 * (1 - np.cos(np.pi * np.clip(t, 0, tr) / tr))))


def _times(ramp: float) -> np.ndarray:
    rng = np.random.default_rng(11)
    dense_ramp = np.linspace(-0.5, max(ramp, 1.0) + 0.5, 2001)  # through the ramp and its ends
    return np.concatenate([dense_ramp, rng.uniform(0, 3600, 3000), [0.0, ramp, 1e-9, 7200.0]])


def _compiled(sig, t: np.ndarray) -> np.ndarray:
    p = sig.packed()
    work = np.empty(p.size)
    return np.array([signal_value(p, 0, float(ti), work) for ti in t])


SINES = [Sine(25000.0, 4.0), Sine(1.5, 7.3, phase=0.4, ramp=20.0), Sine(-3.0, 0.9, -2.0, ramp=0.5)]


@pytest.mark.parametrize("sig", SINES, ids=lambda s: f"A{s.amplitude}_T{s.period}_r{s.ramp}")
def test_sine_equals_the_formula(sig: Sine) -> None:
    t = _times(sig.ramp)
    want = _ramp(t, sig.ramp) * sig.amplitude * np.sin(2 * np.pi * t / sig.period + sig.phase)
    got = _compiled(sig, t)
    assert np.max(np.abs(got - want)) <= REL * abs(sig.amplitude)
    # the Python signal agrees too (the same arithmetic)
    py = np.array([sig(float(ti)) for ti in t])
    assert np.max(np.abs(got - py)) <= REL * abs(sig.amplitude)


JONSWAPS = [
    Jonswap(2.0, 10.0),                                      # 128 components: one pairwise block
    Jonswap(4.0, 8.0, gamma=1.0, seed=5, n_components=300, ramp=30.0),  # split blocks
    Jonswap(1.0, 12.0, seed=2, n_components=13, ramp=2.0),  # 8 partial sums + remainder
    Jonswap(1.0, 12.0, seed=3, n_components=5),             # plain loop
]


@pytest.mark.parametrize("sig", JONSWAPS, ids=lambda s: f"m{s.omega.size}_r{s.ramp}")
def test_jonswap_equals_the_formula(sig: Jonswap) -> None:
    t = _times(sig.ramp)
    a, w, p = sig.amplitude, sig.omega, sig.phase
    want = _ramp(t, sig.ramp) * (a[None, :] * np.cos(w[None, :] * t[:, None] + p[None, :])).sum(axis=1)
    got = _compiled(sig, t)
    scale = np.abs(a).sum()
    assert np.max(np.abs(got - want)) <= REL * scale
    py = np.array([sig(float(ti)) for ti in t])
    assert np.max(np.abs(got - py)) <= REL * scale


def test_constant_and_zero_sources() -> None:
    t = _times(0.0)
    assert np.all(_compiled(Constant(2.5), t) == 2.5)
    for kind in ("none", "topic"):
        assert np.all(_compiled(make_signal(kind, "wave", {}), t) == 0.0)


@pytest.mark.parametrize("n", [1, 7, 8, 9, 16, 100, 128, 129, 255, 256, 1000, 4099])
def test_pairwise_sum_is_a_sum(n: int) -> None:
    rng = np.random.default_rng(n)
    x = rng.normal(size=n + 5) * 10 ** rng.uniform(-3, 3, n + 5)
    exact = math.fsum(x[2:2 + n])
    # pairwise summation: error below ~log2(n) eps sum|x|
    assert abs(pairwise_sum(x, 2, n) - exact) <= 64 * np.finfo(float).eps * np.abs(x).sum()


def test_bound_covers_the_signal() -> None:
    for sig in [*SINES, *JONSWAPS, Constant(-4.0)]:
        t = _times(getattr(sig, "ramp", 0.0))
        assert np.max(np.abs(_compiled(sig, t))) <= signal_bound(sig.packed())


def test_program_adds_the_held_values_and_samples_the_step_times() -> None:
    heave, wave = Sine(1000.0, 5.0, ramp=3.0), Jonswap(2.0, 9.0, seed=4, ramp=3.0)
    prog = pack_program(heave.packed(), wave.packed(), held_u=-250.0, held_eta=0.125)
    work = np.empty(prog.size)
    u, eta = program_inputs(prog, 1.7, work)
    sc = np.abs(wave.amplitude).sum()
    r = _ramp(np.array([1.7]), 3.0)[0]
    assert abs(u - (1000.0 * r * np.sin(2 * np.pi * 1.7 / 5.0) - 250.0)) <= REL * 1000
    assert abs(eta - (wave(1.7) + 0.125)) <= REL * sc
    # held values change in place
    prog[HELD_U], prog[HELD_ETA] = 0.0, 0.0
    u0, eta0 = program_inputs(prog, 1.7, work)
    assert u0 == pytest.approx(u + 250.0, abs=1e-9) and eta0 == pytest.approx(eta - 0.125, abs=1e-12)
    # sample_program: the inputs at t0 + k h + offset h, and their largest magnitudes
    t0, h, offs = 2.0, 0.01, np.array([0.0, 0.5, 1.0])
    us, es = np.empty((40, 3)), np.empty((40, 3))
    umax, emax = sample_program(prog, t0, h, offs, us, es)
    tt = (t0 + np.arange(40)[:, None] * h) + offs[None, :] * h
    assert np.max(np.abs(us - 1000.0 * _ramp(tt, 3.0) * np.sin(2 * np.pi * tt / 5.0))) <= REL * 1000
    assert np.max(np.abs(es - np.vectorize(wave)(tt))) <= REL * sc
    assert umax == np.abs(us).max() and emax == np.abs(es).max()
