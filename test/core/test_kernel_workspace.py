"""The compiled kernels' workspace paths against their allocating paths.

The compiled steppers call :func:`cable_sim.core.kernel.forward.fd_packed_ws` and
:func:`cable_sim.core.kernel.joint_forces.joint_forces_packed_ws` with scratch allocated once
per run. A reused workspace must carry nothing from one call to the next: with one workspace
per n, first filled with NaN and then used in turn for every model (free, anchored, heavy
load, seabed with added mass, n = 1 and 2 where the workspace is wider than n + 1) and state,
each call must give what the allocating call (fresh scratch) gives for the same inputs.
"""

from __future__ import annotations

import numpy as np
import pytest

from cable_sim.core.kernel.forward import fd_packed, fd_packed_ws, fd_trig, fd_workspace
from cable_sim.core.kernel.joint_forces import jf_workspace, joint_forces_packed, joint_forces_packed_ws
from cable_sim.core.kernel.packing import pack_arrays
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams
from cable_sim.scene.scenes import load_scene

RTOL = 1e-12


def _models(n: int) -> list[CableModel]:
    """Free (paper drag), anchored on a seabed (Morison, added mass), heavy load, free Morison."""
    scenes = [load_scene("paper_free_fall"), load_scene("mooring_line"),
              load_scene("paper_anchored_forced", {"end_condition": "paper_anchor"}),
              load_scene("control_experiment")]
    if n <= 2:
        ends = ("free", "paper_anchor") + (("anchored",) if n > 1 else ())
        return [CableModel.from_params(CableParams(n_links=n, end_condition=end, drag_model=drag))
                for end in ends for drag in ("paper", "morison")]
    return [s.with_links(n).model() for s in scenes]


def _state(model: CableModel, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = model.n
    q = np.concatenate([[rng.normal()], rng.uniform(0.2, 1.4, n)])
    if model.seabed:  # put part of the line into the bed
        q[0] = model.seabed_z + 0.5 * float(np.sum(model.length))
    qd = np.concatenate([[rng.normal()], rng.normal(size=n)])
    return q, qd


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(a)) and np.linalg.norm(a - b) <= RTOL * max(np.linalg.norm(b), 1e-300))


@pytest.mark.parametrize("n", [1, 2, 13])
def test_reused_workspace_matches_fresh(n: int) -> None:
    models = _models(n)
    ws = fd_workspace(n)
    ws[:] = np.nan
    jw = jf_workspace(n)
    jw[:] = np.nan
    out_ws = np.full((n + 1, 2), np.nan)
    order = [(m, s) for s in range(3) for m in models]
    order += order[::-1]  # every model after every other
    for model, seed in order:
        arr, par = pack_arrays(model)
        q, qd = _state(model, seed)
        u, eta = 300.0 * (seed - 1), 0.4
        qdd0, lam0 = np.empty(n + 1), np.empty(2)
        ok0 = fd_packed(arr, par, u, eta, q, qd, qdd0, lam0)
        qdd1, lam1 = np.full(n + 1, np.nan), np.full(2, np.nan)
        ok1 = fd_packed_ws(arr, par, u, eta, q, qd, qdd1, lam1, ws)
        assert ok0 == ok1
        if not ok0:
            continue
        assert _close(qdd1, qdd0) and _close(lam1, lam0)
        cth, sth = fd_trig(ws, n)
        np.testing.assert_allclose(cth, np.cos(q[1:]), rtol=0, atol=1e-15)
        np.testing.assert_allclose(sth, np.sin(q[1:]), rtol=0, atol=1e-15)
        # the allocating joint forces take numpy's (libm) cos/sin: give the workspace path those
        F0 = joint_forces_packed(arr, par, lam0[0], lam0[1], q, qd, qdd0)
        joint_forces_packed_ws(arr, par, lam0[0], lam0[1], q, qd, qdd0, np.cos(q[1:]),
                               np.sin(q[1:]), jw, out_ws)
        assert _close(out_ws, F0)
