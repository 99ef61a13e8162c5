"""The branch-free cos/sin of the link angles against numpy's (libm) cos and sin: within a few
units in the last place for every octant, both signs and magnitudes up to 1e7, exact at zero,
and the libm values beyond :data:`cable_sim.core.kernel.trig.LARGE`; NaN for non-finite angles."""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core.kernel.links import link_trig
from cable_sim.core.kernel.trig import LARGE


def _trig(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q = np.concatenate([[0.0], angles])
    c = np.empty(angles.size)
    s = np.empty(angles.size)
    link_trig(q, c, s)
    return c, s


@pytest.mark.parametrize("scale", [1.0, 4.0, 60.0, 1e4, 1e7])
def test_matches_libm(scale: float) -> None:
    rng = np.random.default_rng(int(scale))
    x = rng.uniform(-scale, scale, 50001)
    c, s = _trig(x)
    assert np.max(np.abs(c - np.cos(x))) <= 2.5e-16
    assert np.max(np.abs(s - np.sin(x))) <= 2.5e-16
    # relative: a few units in the last place (sin near its zeros too)
    assert np.all(np.abs(s - np.sin(x)) <= 4 * np.spacing(np.abs(np.sin(x))))
    assert np.all(np.abs(c - np.cos(x)) <= 4 * np.spacing(np.abs(np.cos(x))))


def test_octant_edges_and_special_values() -> None:
    k = np.arange(-16, 17)
    x = np.concatenate([k * np.pi / 4, np.nextafter(k * np.pi / 4, np.inf),
                        np.nextafter(k * np.pi / 4, -np.inf), [0.0, -0.0, 1e-300, -5e-324]])
    c, s = _trig(x)
    np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=2.5e-16)
    np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=2.5e-16)
    c, s = _trig(np.array([0.0, 1e-300]))
    assert c[0] == 1.0 and s[0] == 0.0 and s[1] == 1e-300
    big = np.array([2.0 * LARGE, -3.0e12, 1e300])
    c, s = _trig(big)
    np.testing.assert_array_equal(c, np.cos(big))
    np.testing.assert_array_equal(s, np.sin(big))
    c, s = _trig(np.array([np.nan, np.inf, -np.inf]))
    assert np.all(np.isnan(c)) and np.all(np.isnan(s))
