"""Peaks and most probable maxima (MPM) of tension series.

Two methods, both stated in the results:

- Per case (``*_mpm`` columns): narrow-band Gaussian (Rayleigh-distributed peaks) estimate
  ``MPM = mean + std * sqrt(2 ln N)`` with N the number of mean up-crossings in the record
  (the mode of the largest of N Rayleigh peaks, to leading order).
- Per sea state (second table ``extremes.parquet``): a Gumbel distribution fitted to the per-seed
  maxima by the method of moments, ``beta = s sqrt(6) / pi``, ``mu = mean - 0.5772 beta``; the
  MPM is the mode ``mu`` (and the 90 % quantile is given too).
"""

from __future__ import annotations

import math

import numpy as np

EULER_GAMMA = 0.5772156649015329


def upcrossing_peaks(x: np.ndarray) -> np.ndarray:
    """Largest value between consecutive up-crossings of the mean (one peak per cycle)."""
    x = np.asarray(x, dtype=float)
    if x.size < 3:
        return np.empty(0)
    d = x - x.mean()
    up = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0)) + 1
    if up.size < 2:
        return np.empty(0)
    return np.array([x[a:b].max() for a, b in zip(up[:-1], up[1:], strict=False)])


def mpm_rayleigh(x: np.ndarray) -> tuple[float, int]:
    """Narrow-band Gaussian MPM ``mean + std sqrt(2 ln N)``, N = mean up-crossings; (nan, N) if N < 2."""
    x = np.asarray(x, dtype=float)
    d = x - x.mean()
    n = int(np.count_nonzero((d[:-1] < 0) & (d[1:] >= 0)))
    if n < 2:
        return float("nan"), n
    return float(x.mean() + x.std() * math.sqrt(2.0 * math.log(n))), n


def gumbel_fit(maxima: np.ndarray) -> tuple[float, float]:
    """Method-of-moments Gumbel fit (location mu, scale beta) of a sample of maxima.

    ``beta = s sqrt(6)/pi`` (s the sample standard deviation, ddof=1), ``mu = mean - gamma beta``.
    With one sample, beta = 0 and mu = that maximum.
    """
    m = np.asarray(maxima, dtype=float)
    m = m[np.isfinite(m)]
    if m.size == 0:
        return float("nan"), float("nan")
    if m.size == 1:
        return float(m[0]), 0.0
    beta = float(np.std(m, ddof=1)) * math.sqrt(6.0) / math.pi
    return float(m.mean() - EULER_GAMMA * beta), beta


def gumbel_quantile(mu: float, beta: float, p: float) -> float:
    """Value not exceeded with probability p: ``mu - beta ln(-ln p)``."""
    return mu - beta * math.log(-math.log(p))


def sea_state_table(rows: list[dict], keys: list[str]) -> list[dict]:
    """Per-sea-state extremes: Gumbel fit of the per-case (seed) maxima of fairlead and anchor tension.

    Parameters
    ----------
    rows : list of dict
        Result rows (only rows with status ``ok`` are used).
    keys : list of str
        Input keys defining a sea state (present in the rows; the others, e.g. seeds, are pooled).
    """
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("status") != "ok":
            continue
        k = tuple(r.get(key) for key in keys)
        groups.setdefault(k, []).append(r)
    out = []
    for k, rs in groups.items():
        row = dict(zip(keys, k, strict=False))
        row["n_seeds"] = len(rs)
        for end in ("fairlead", "anchor"):
            mx = np.array([r[f"{end}_max"] for r in rs], dtype=float)
            mu, beta = gumbel_fit(mx)
            row[f"{end}_max_mean"] = float(mx.mean())
            row[f"{end}_gumbel_mu"] = mu
            row[f"{end}_gumbel_beta"] = beta
            row[f"{end}_mpm"] = mu
            row[f"{end}_p90"] = gumbel_quantile(mu, beta, 0.9) if math.isfinite(beta) else float("nan")
        row["method"] = "Gumbel method-of-moments fit of per-seed maxima; MPM = mode mu"
        out.append(row)
    return out


__all__ = ["upcrossing_peaks", "mpm_rayleigh", "gumbel_fit", "gumbel_quantile", "sea_state_table"]
