"""Rainflow/Miner against the independent ``rainflow`` package and ASTM E1049; MPM on known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cable_sim.analysis.batch.extremes import gumbel_fit, mpm_rayleigh
from cable_sim.analysis.batch.fatigue import TN_DEFAULTS, miner_damage, rainflow_cycles, tn_curve_from_dict
from cable_sim.core.params import ParameterError

rainflow = pytest.importorskip("rainflow")


def _reference_damage(x: np.ndarray, a_d: float, m: float, area: float) -> float:
    d = 0.0
    for rng, _mean, count, _i0, _i1 in rainflow.extract_cycles(x):
        d += count * (rng / area / 1e6) ** m
    return d / a_d


def test_astm_e1049_example():
    """ASTM E1049-85 fig. 6 example: ranges 3 x0.5, 4 x1.5, 6 x0.5, 8 x1, 9 x0.5."""
    cyc = rainflow_cycles(np.array([-2, 1, -3, 5, -1, 3, -4, 4, -2], dtype=float))
    counts: dict[float, float] = {}
    for rng, _mean, n in cyc:
        counts[rng] = counts.get(rng, 0.0) + n
    assert counts == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}


@pytest.mark.parametrize("kind", list(TN_DEFAULTS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_damage_matches_rainflow_package(kind, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(20000) * 0.1
    # a tension-like history: mean + wave-frequency + slow drift + noise (+ repeated plateaus)
    x = 4e5 + 8e4 * np.sin(2 * np.pi * t / 9.0) + 3e4 * np.sin(2 * np.pi * t / 95.0) \
        + 2e4 * rng.standard_normal(t.size)
    x[100:110] = x[100]
    curve = tn_curve_from_dict({"type": kind, "nominal_diameter": 0.076})
    area = curve.nominal_area(0.0)
    assert area == pytest.approx(TN_DEFAULTS[kind][2] * math.pi * 0.076**2 / 4, rel=1e-15)
    ours = miner_damage(x, curve, area)
    ref = _reference_damage(x, curve.a_d, curve.m, area)
    assert ours > 0
    assert abs(ours - ref) <= 1e-9 * ref


def test_tn_curve_errors_name_key():
    with pytest.raises(ParameterError, match="tn_curve.type"):
        tn_curve_from_dict({"type": "rope"})
    with pytest.raises(ParameterError, match="tn_curve.m"):
        tn_curve_from_dict({"type": "custom", "a_d": 1e10})
    with pytest.raises(ParameterError, match="nominal_diameter"):
        tn_curve_from_dict({"nominal_diameter": -1})


def test_gumbel_mode_of_rayleigh_maxima():
    """Max of N iid Rayleigh(sigma) peaks: exact mode of (1 - exp(-x^2/2s^2))^N vs the fitted mode."""
    sigma, n = 2.0, 1000
    rng = np.random.default_rng(5)
    maxima = rng.rayleigh(sigma, size=(4000, n)).max(axis=1)
    mu, beta = gumbel_fit(maxima)
    x = np.linspace(4.0, 12.0, 200001)
    u = np.exp(-(x**2) / (2 * sigma**2))
    logpdf = np.log(n) + (n - 1) * np.log1p(-u) + np.log(x / sigma**2) - x**2 / (2 * sigma**2)
    exact_mode = x[np.argmax(logpdf)]
    assert mu == pytest.approx(exact_mode, rel=0.01)
    # and the narrow-band formula sigma sqrt(2 ln N) is that mode to leading order
    assert sigma * math.sqrt(2 * math.log(n)) == pytest.approx(exact_mode, rel=0.01)


def test_rayleigh_mpm_on_narrow_band_series():
    """Gaussian narrow-band sea: std and up-crossing count from the spectrum, MPM within 3 %."""
    rng = np.random.default_rng(3)
    w = np.linspace(0.95, 1.05, 100)  # rad/s, narrow band
    a = np.full(w.size, 1.0 / math.sqrt(w.size))  # sigma^2 = sum a^2 / 2 = 0.5
    ph = rng.uniform(0, 2 * np.pi, w.size)
    t = np.arange(0.0, 20000.0, 0.25)
    x = 10.0 + (a[:, None] * np.cos(w[:, None] * t[None, :] + ph[:, None])).sum(axis=0)
    m0, m2 = np.sum(a**2 / 2), np.sum(a**2 / 2 * w**2)
    n_expected = t[-1] * math.sqrt(m2 / m0) / (2 * math.pi)
    mpm, n = mpm_rayleigh(x)
    assert n == pytest.approx(n_expected, rel=0.03)
    assert mpm == pytest.approx(10.0 + math.sqrt(m0) * math.sqrt(2 * math.log(n_expected)), rel=0.03)
