"""The inward sweeps' change of frame (:func:`cable_sim.core.kernel.frames.to_parent_frame`)
against the rotation of the 2x2 matrix written out with numpy: ``t^T A t, t^T A e, e^T A e``
of a symmetric A given in another link's frame (t', e'), ``t = (cos, sin)``, ``e = (sin, -cos)``.
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core.kernel.frames import relative_trig, to_parent_frame


def _frame(th: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([np.cos(th), np.sin(th)]), np.array([np.sin(th), -np.cos(th)])


@pytest.mark.parametrize("seed", range(5))
def test_to_parent_frame_matches_the_rotated_matrix(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(50):
        th_child, th_parent = rng.uniform(-4.0, 4.0, 2)
        p, u = rng.uniform(0.1, 10.0, 2)
        r = rng.uniform(-1.0, 1.0) * np.sqrt(p * u)  # A positive definite
        tc, ec = _frame(th_child)
        a_world = (p * np.outer(tc, tc) + r * (np.outer(tc, ec) + np.outer(ec, tc))
                   + u * np.outer(ec, ec))
        t, e = _frame(th_parent)
        expected = (t @ a_world @ t, t @ a_world @ e, e @ a_world @ e)
        cr, sr = relative_trig(np.cos(th_parent), np.sin(th_parent), np.cos(th_child),
                               np.sin(th_child))
        got = to_parent_frame(p, r, u, cr, sr)
        scale = p + u
        np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-13 * scale)


def test_isotropic_matrix_has_no_cross_term() -> None:
    for th in np.linspace(-3.0, 3.0, 13):
        cr, sr = relative_trig(1.0, 0.0, np.cos(th), np.sin(th))
        assert to_parent_frame(7.5, 0.0, 7.5, cr, sr)[1] == 0.0
