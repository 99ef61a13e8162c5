"""The O(n) compiled kernel :mod:`cable_sim.core.kernel` against three references.

1. The dense Cholesky solver :mod:`cable_sim.core.dynamics` (free and anchored ends), for every end
   condition x drag model x heave lock, n in {1, 2, 5, 17, 60}, random seeded states, nonzero
   inputs and current: qdd and the anchor force must agree to 1e-9 relative (norm-wise).
2. For the paper's anchor emulation (an 8e8 kg load) the dense float64 solve is itself only good
   to ~kappa(M) eps (measured up to ~2e-6 relative at n = 60), so there the reference is the same
   closed-form equations of MODEL.md evaluated and solved in 40-digit arithmetic (mpmath).
3. An independent Euler-Lagrange derivation with sympy (MODEL.md asks for it) for n = 2, 3.

Run ``python test/test_fast_kernel.py`` to print per-call timings for n = 100, 1000, 10000.
"""

from __future__ import annotations

import functools
import time

import mpmath
import numpy as np
import pytest
import sympy as sp
from kernel_models import make_model

from cable_sim.core import dynamics as dense
from cable_sim.core import kernel as fast
from cable_sim.core.dynamics import Inputs
from cable_sim.core.model import CableModel
from cable_sim.core.params import CableParams, ParameterError

RTOL = 1e-9
NS = (1, 2, 5, 17, 60)
ENDS = ("free", "anchored", "paper_anchor")
DRAGS = ("none", "paper", "morison")


def random_state(model: CableModel, seed: int) -> tuple[np.ndarray, np.ndarray, Inputs]:
    rng = np.random.default_rng(seed)
    n = model.n
    q = np.concatenate([[rng.normal()], rng.uniform(-1.4, 1.4, n)])
    qd = np.concatenate([[rng.normal()], rng.normal(size=n)])
    inputs = Inputs(heave_force=2.0e4 * rng.normal(), wave_elevation=rng.normal())
    return q, qd, inputs


def rel_err(x: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(np.asarray(x) - ref) / np.linalg.norm(ref))


def cases():
    for n in NS:
        for end in ENDS:
            for drag in DRAGS:
                for locked in (False, True):
                    if end == "anchored" and n + (0 if locked else 1) - 2 < 1:
                        continue  # no free dof: refused by CableParams (test_overconstrained...)
                    yield n, end, drag, locked


# --------------------------------------------------------------------------------------------
# High-precision reference: the MODEL.md closed forms in mpmath
# --------------------------------------------------------------------------------------------


def mp_forward(
    model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs, dps: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Forward dynamics from the MODEL.md closed forms, assembled and solved with ``dps`` digits."""
    with mpmath.workdps(dps):
        mpf = mpmath.mpf
        n = model.n
        l = [mpf(float(x)) for x in model.length]
        m = [mpf(float(x)) for x in model.mass]
        mw = [mpf(float(x)) for x in model.weight_mass]
        mc, mcw, g = mpf(model.load_mass), mpf(model.load_weight_mass), mpf(model.gravity)
        th = [mpf(float(x)) for x in q[1:]]
        w = [mpf(float(x)) for x in qd[1:]]
        sn = [mpmath.sin(x) for x in th]
        cs = [mpmath.cos(x) for x in th]
        below, below_w = [mpf(0)] * n, [mpf(0)] * n
        acc, acc_w = mc, mcw
        for i in range(n - 1, -1, -1):
            below[i], below_w[i] = acc, acc_w
            acc += m[i]
            acc_w += mw[i]
        mu = [m[i] / 2 + below[i] for i in range(n)]
        mu_w = [mw[i] / 2 + below_w[i] for i in range(n)]
        N = n + 1
        M = mpmath.zeros(N, N)
        M[0, 0] = mpf(model.platform_mass) + sum(m) + mc
        for j in range(n):
            M[0, j + 1] = M[j + 1, 0] = mu[j] * l[j] * sn[j]
            for i in range(n):
                if i == j:
                    M[i + 1, i + 1] = (m[i] / 3 + below[i]) * l[i] ** 2
                else:
                    # cos(a - b) expanded: exact in mp, cheaper than n^2 cosines
                    cij = cs[i] * cs[j] + sn[i] * sn[j]
                    M[i + 1, j + 1] = mu[max(i, j)] * l[i] * l[j] * cij
        rhs = [mpf(0)] * N
        rhs[0] = mpf(inputs.heave_force) - g * (sum(mw) + mcw)
        if model.wave_coupling:
            rhs[0] += mpf(model.heave_k) * mpf(inputs.wave_elevation)
        rhs[0] -= mpf(model.heave_k) * mpf(float(q[0])) + mpf(model.heave_c) * mpf(float(qd[0]))
        rhs[0] -= sum(mu[j] * l[j] * cs[j] * w[j] ** 2 for j in range(n))
        tau = []
        for i in range(n):
            dth = th[i] - (th[i - 1] if i else 0)
            dw = w[i] - (w[i - 1] if i else 0)
            tau.append(mpf(float(model.joint_k[i])) * dth + mpf(float(model.joint_c[i])) * dw)
        tau.append(mpf(0))
        for i in range(n):
            b_i = sum(
                mu[max(i, j)] * l[i] * l[j] * (sn[i] * cs[j] - cs[i] * sn[j]) * w[j] ** 2
                for j in range(n)
                if j != i
            )
            rhs[i + 1] = -b_i - g * mu_w[i] * l[i] * sn[i] - tau[i] + tau[i + 1]
        if model.drag == 1:
            for i in range(n):
                rhs[i + 1] -= mpf(float(model.drag_gamma_l2[i])) * w[i] * abs(w[i])
        elif model.drag == 2:
            vx, vz = mpf(0), mpf(float(qd[0]))
            f = []
            for i in range(n):
                vcx = vx + l[i] * cs[i] * w[i] / 2 - mpf(model.current)
                vcz = vz + l[i] * sn[i] * w[i] / 2
                vt = vcx * sn[i] - vcz * cs[i]
                vnx, vnz = vcx - vt * sn[i], vcz + vt * cs[i]
                vn = mpmath.sqrt(vnx**2 + vnz**2)
                cn, ct = mpf(float(model.morison_cn[i])), mpf(float(model.morison_ct[i]))
                f.append((-cn * vn * vnx - ct * abs(vt) * vt * sn[i],
                          -cn * vn * vnz + ct * abs(vt) * vt * cs[i]))
                vx += l[i] * cs[i] * w[i]
                vz += l[i] * sn[i] * w[i]
            rhs[0] += sum(fi[1] for fi in f)
            sx, sz = mpf(0), mpf(0)
            for j in range(n - 1, -1, -1):
                rhs[j + 1] += l[j] * (cs[j] * (f[j][0] / 2 + sx) + sn[j] * (f[j][1] / 2 + sz))
                sx += f[j][0]
                sz += f[j][1]
        idx = list(range(1 if model.heave_locked else 0, N))
        k = len(idx)
        nc = 2 if model.constrained else 0
        K = mpmath.zeros(k + nc, k + nc)
        r = mpmath.zeros(k + nc, 1)
        for a in range(k):
            r[a] = rhs[idx[a]]
            for b in range(k):
                K[a, b] = M[idx[a], idx[b]]
        if model.constrained:
            J = [[mpf(0)] + [l[i] * cs[i] for i in range(n)],
                 [mpf(1)] + [l[i] * sn[i] for i in range(n)]]
            phi = [sum(l[i] * sn[i] for i in range(n)) - mpf(float(model.anchor[0])),
                   mpf(float(q[0])) - sum(l[i] * cs[i] for i in range(n))
                   - mpf(float(model.anchor[1]))]
            qdm = [mpf(float(x)) for x in qd]
            phid = [sum(J[c][j] * qdm[j] for j in range(N)) for c in range(2)]
            bias = [-sum(l[i] * sn[i] * w[i] ** 2 for i in range(n)),
                    sum(l[i] * cs[i] * w[i] ** 2 for i in range(n))]
            al, be = mpf(model.baumgarte_alpha), mpf(model.baumgarte_beta)
            for c in range(2):
                r[k + c] = bias[c] + 2 * al * phid[c] + be**2 * phi[c]  # = -gamma
                for a in range(k):
                    K[a, k + c] = K[k + c, a] = -J[c][idx[a]]
        x = mpmath.lu_solve(K, r)
        qdd = np.zeros(N)
        for a in range(k):
            qdd[idx[a]] = float(x[a])
        lam = np.array([float(x[k]), float(x[k + 1])]) if nc else np.zeros(2)
    return qdd, lam


# --------------------------------------------------------------------------------------------
# 1 + 2: fast kernel vs the dense solver (and vs mpmath for the paper anchor)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("n", "end", "drag", "locked"), list(cases()))
def test_forward_dynamics_matches_reference(n: int, end: str, drag: str, locked: bool) -> None:
    model = make_model(n, end, drag, locked)
    for seed in range(2):
        q, qd, inputs = random_state(model, 7919 * n + 31 * seed + 3 * locked)
        qdd, lam = fast.forward_dynamics(model, q, qd, inputs)
        assert qdd.shape == (n + 1,) and lam.shape == (2,)
        if end == "paper_anchor":
            if n == 60 and seed == 1:
                continue  # the 40-digit reference costs ~0.5 s here; one state is enough
            ref_qdd, ref_lam = mp_forward(model, q, qd, inputs)
        else:
            ref_qdd, ref_lam = dense.forward_dynamics(model, q, qd, inputs)
        assert rel_err(qdd, ref_qdd) <= RTOL
        if end == "anchored":
            assert rel_err(lam, ref_lam) <= RTOL
        else:
            assert np.all(lam == 0.0)
        if locked:
            assert qdd[0] == 0.0
        ydot = fast.state_derivative(model, np.concatenate([q, qd]), inputs)
        np.testing.assert_array_equal(ydot, np.concatenate([qd, qdd]))


@pytest.mark.parametrize("n", NS)
def test_heavy_free_load_matches_dense(n: int) -> None:
    """A free load heavier than the line takes the Woodbury path; its weight must be kept."""
    for locked in (False, True):
        model = make_model(n, "free", "morison", locked)
        model = CableModel.from_params(model.params.replace(load_mass=3000.0, load_volume=0.2))
        assert model.load_mass > model.mass.sum() and model.load_weight_mass > 0.0
        q, qd, inputs = random_state(model, 4242 + n)
        qdd, lam = fast.forward_dynamics(model, q, qd, inputs)
        ref_qdd, _ = dense.forward_dynamics(model, q, qd, inputs)
        assert rel_err(qdd, ref_qdd) <= RTOL
        assert np.all(lam == 0.0)


@pytest.mark.parametrize("end", ["anchored", "free"])
def test_dense_matches_mp_reference(end: str) -> None:
    """The 40-digit reference itself agrees with the dense solver where that is well conditioned."""
    model = make_model(5, end, "morison", False)
    q, qd, inputs = random_state(model, 11)
    ref_qdd, ref_lam = mp_forward(model, q, qd, inputs)
    qdd, lam = dense.forward_dynamics(model, q, qd, inputs)
    assert rel_err(qdd, ref_qdd) <= RTOL  # measured ~1e-15: well conditioned; RTOL leaves CPU margin
    if end == "anchored":
        assert rel_err(lam, ref_lam) <= RTOL


def test_default_inputs() -> None:
    """``inputs`` defaults to NO_INPUT (zero heave force, still water)."""
    for end in ENDS:
        model = make_model(17, end, "paper", False)
        q, qd, _ = random_state(model, 5)
        qdd, lam = fast.forward_dynamics(model, q, qd)
        qdd0, lam0 = fast.forward_dynamics(model, q, qd, Inputs(0.0, 0.0))
        np.testing.assert_array_equal(qdd, qdd0)
        np.testing.assert_array_equal(lam, lam0)
        qdd1, _ = fast.forward_dynamics(model, q, qd, Inputs(1.0e3, 0.0))
        assert not np.array_equal(qdd, qdd1)


def test_overconstrained_anchor_raises() -> None:
    """An anchored line with no free dof (two constraint equations against <= 2 dof) is refused
    at the boundary, naming the parameter, before any solver sees it."""
    for n, locked in ((1, False), (1, True), (2, True)):
        with pytest.raises(ParameterError, match="n_links"):
            make_model(n, "anchored", "none", locked)


def test_energy_and_joint_forces_match_dense() -> None:
    for n in NS:
        for end in ENDS:
            for drag in DRAGS:
                if end == "anchored" and n < 2:
                    continue  # no free dof: refused by CableParams
                model = make_model(n, end, drag, False)
                q, qd, inputs = random_state(model, 17 * n)
                T, V = fast.energy(model, q, qd)
                assert isinstance(T, float) and isinstance(V, float)
                assert abs(T - dense.kinetic_energy(model, q, qd)) <= RTOL * abs(T)
                assert abs(V - dense.potential_energy(model, q)) <= RTOL * abs(V)
                qdd, lam = fast.forward_dynamics(model, q, qd, inputs)
                F = fast.joint_forces(model, q, qd, qdd, lam)
                assert rel_err(F, dense.joint_forces(model, q, qd, qdd, lam)) <= RTOL
                F0 = fast.joint_forces(model, q, qd, qdd)
                assert rel_err(F0, dense.joint_forces(model, q, qd, qdd)) <= RTOL


def test_anchored_joint_force_balance() -> None:
    """Anchored: the recursion's end force is minus the anchor reaction."""
    model = make_model(17, "anchored", "morison", False)
    q, qd, inputs = random_state(model, 3)
    qdd, lam = fast.forward_dynamics(model, q, qd, inputs)
    F = fast.joint_forces(model, q, qd, qdd, lam)
    np.testing.assert_array_equal(F[-1], -lam)


def test_bad_shapes_rejected() -> None:
    model = make_model(5, "free", "none", False)
    with pytest.raises(ValueError):
        fast.forward_dynamics(model, np.zeros(5), np.zeros(6))
    with pytest.raises(ValueError):
        fast.state_derivative(model, np.zeros(11))


def test_warmup_runs() -> None:
    fast.warmup()


# --------------------------------------------------------------------------------------------
# 3: independent symbolic Euler-Lagrange derivation (sympy), n = 2 and 3
# --------------------------------------------------------------------------------------------


@functools.cache
def lagrange(n: int):
    """Lambdified M(q), the conservative + dissipative generalised force, and kinematics."""
    z, zd = sp.symbols("z zd")
    th = sp.symbols(f"th1:{n + 1}")
    w = sp.symbols(f"w1:{n + 1}")
    l = sp.symbols(f"l1:{n + 1}")
    m = sp.symbols(f"m1:{n + 1}")
    mw = sp.symbols(f"mw1:{n + 1}")
    k = sp.symbols(f"k1:{n + 1}")
    c = sp.symbols(f"c1:{n + 1}")
    mc, mcw, Mp, km, cm, g = sp.symbols("mc mcw Mp km cm g")
    qs, vs = [z, *th], [zd, *w]
    px, pz = [sp.Integer(0)], [z]
    for i in range(n):
        px.append(px[-1] + l[i] * sp.sin(th[i]))
        pz.append(pz[-1] - l[i] * sp.cos(th[i]))
    cx = [(px[i] + px[i + 1]) / 2 for i in range(n)]
    cz = [(pz[i] + pz[i + 1]) / 2 for i in range(n)]

    def vel(expr):
        return sum(sp.diff(expr, qi) * vi for qi, vi in zip(qs, vs, strict=True))

    T = Mp * zd**2 / 2 + mc * (vel(px[n]) ** 2 + vel(pz[n]) ** 2) / 2
    for i in range(n):
        T += m[i] * (vel(cx[i]) ** 2 + vel(cz[i]) ** 2) / 2 + m[i] * l[i] ** 2 / 24 * w[i] ** 2
    rel = [th[0]] + [th[i] - th[i - 1] for i in range(1, n)]
    reld = [w[0]] + [w[i] - w[i - 1] for i in range(1, n)]
    V = g * (sum(mw[i] * cz[i] for i in range(n)) + mcw * pz[n]) + km * z**2 / 2
    V += sum(k[i] * rel[i] ** 2 for i in range(n)) / 2
    R = cm * zd**2 / 2 + sum(c[i] * reld[i] ** 2 for i in range(n)) / 2  # Rayleigh
    vT = sp.Matrix([T])
    Mmat = sp.hessian(T, vs)
    dTdv = vT.jacobian(vs)
    force = (
        vT.jacobian(qs)
        - (dTdv.jacobian(qs) * sp.Matrix(vs)).T
        - sp.Matrix([V]).jacobian(qs)
        - sp.Matrix([R]).jacobian(vs)
    ).T
    Jc = [sp.Matrix([cx[i], cz[i]]).jacobian(qs) for i in range(n)]
    Jend = sp.Matrix([px[n], pz[n]]).jacobian(qs)
    end_bias = (Jend * sp.Matrix(vs)).jacobian(qs) * sp.Matrix(vs)
    args = (qs, vs, l, m, mw, k, c, mc, mcw, Mp, km, cm, g)
    f = functools.partial(sp.lambdify, args, modules="numpy", cse=True)
    return (f(Mmat), f(force), [f(J) for J in Jc], f(Jend), f(end_bias),
            sp.lambdify(args, sp.Matrix([px[n], pz[n]]), modules="numpy"))


def sympy_forward(model: CableModel, q: np.ndarray, qd: np.ndarray, inputs: Inputs):
    Mf, ff, Jcf, Jef, ebf, pend = lagrange(model.n)
    args = (list(q), list(qd), list(model.length), list(model.mass), list(model.weight_mass),
            list(model.joint_k), list(model.joint_c), model.load_mass, model.load_weight_mass,
            model.platform_mass, model.heave_k, model.heave_c, model.gravity)
    M = np.array(Mf(*args), dtype=float)
    Q = np.array(ff(*args), dtype=float).ravel()
    Q[0] += inputs.heave_force + (model.heave_k * inputs.wave_elevation if model.wave_coupling
                                  else 0.0)
    w = qd[1:]
    if model.drag == 1:
        Q[1:] -= model.drag_gamma_l2 * w * np.abs(w)
    elif model.drag == 2:  # MODEL.md Morison force at each centre, mapped by J_c^T
        for i, Jf in enumerate(Jcf):
            J = np.array(Jf(*args), dtype=float)
            v = J @ qd - np.array([model.current, 0.0])
            e = np.array([np.sin(q[i + 1]), -np.cos(q[i + 1])])
            vt = (v @ e) * e
            vn = v - vt
            F = -model.morison_cn[i] * np.linalg.norm(vn) * vn
            F -= model.morison_ct[i] * abs(v @ e) * vt
            Q += J.T @ F
    s = 1 if model.heave_locked else 0
    qdd = np.zeros(model.n + 1)
    lam = np.zeros(2)
    if model.constrained:
        J = np.array(Jef(*args), dtype=float)
        phi = np.array(pend(*args), dtype=float).ravel() - model.anchor
        gamma = (-np.array(ebf(*args), dtype=float).ravel()
                 - 2 * model.baumgarte_alpha * (J @ qd) - model.baumgarte_beta**2 * phi)
        k = model.n + 1 - s
        K = np.zeros((k + 2, k + 2))
        K[:k, :k] = M[s:, s:]
        K[:k, k:] = -J[:, s:].T
        K[k:, :k] = -J[:, s:]
        x = np.linalg.solve(K, np.concatenate([Q[s:], -gamma]))
        qdd[s:], lam = x[:k], x[k:]
    else:
        qdd[s:] = np.linalg.solve(M[s:, s:], Q[s:])
    return qdd, lam, 0.5 * qd @ M @ qd


@pytest.mark.parametrize("n", [2, 3])
@pytest.mark.parametrize("end", ["free", "anchored"])
def test_fast_matches_sympy_lagrange(n: int, end: str) -> None:
    for drag in DRAGS:
        for locked in (False, True):
            if end == "anchored" and n + (0 if locked else 1) - 2 < 1:
                continue  # no free dof: refused by CableParams
            model = make_model(n, end, drag, locked)
            q, qd, inputs = random_state(model, 101 * n + 7 * locked)
            qdd, lam = fast.forward_dynamics(model, q, qd, inputs)
            ref_qdd, ref_lam, ref_T = sympy_forward(model, q, qd, inputs)
            assert rel_err(qdd, ref_qdd) <= RTOL
            if end == "anchored":
                assert rel_err(lam, ref_lam) <= RTOL
            T, _ = fast.energy(model, q, qd)
            assert abs(T - ref_T) <= RTOL * ref_T


# --------------------------------------------------------------------------------------------
# timings (not a test): python test/test_fast_kernel.py
# --------------------------------------------------------------------------------------------


def _per_call(fn, model: CableModel, q: np.ndarray, qd: np.ndarray, reps: int) -> float:
    fn(model, q, qd)
    t0 = time.perf_counter()
    for _ in range(reps):
        fn(model, q, qd)
    return (time.perf_counter() - t0) / reps


def main() -> None:
    fast.warmup()
    rng = np.random.default_rng(0)
    for end, drag in (("free", "morison"), ("anchored", "paper"), ("paper_anchor", "none")):
        for n in (100, 1000, 10000):
            model = CableModel.from_params(
                CableParams(n_links=n, end_condition=end, drag_model=drag, current_speed=0.5)
            )
            q = np.concatenate([[0.1], rng.uniform(-1.0, 1.0, n)])
            qd = 0.1 * rng.normal(size=n + 1)
            tf = _per_call(fast.forward_dynamics, model, q, qd, max(5, 200000 // n))
            td = float("nan")  # dense at n = 10000 needs an 800 MB matrix: not run
            if n <= 1000:
                td = _per_call(dense.forward_dynamics, model, q, qd, 3 if n > 100 else 30)
            print(f"{end:13s} {drag:8s} n={n:6d}  fast {tf * 1e6:9.1f} us  "
                  f"dense {td * 1e6:10.1f} us  fast per link {tf / n * 1e9:6.1f} ns")


if __name__ == "__main__":
    main()
