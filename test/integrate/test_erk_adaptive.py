"""The adaptive explicit pairs DOPRI5 and Tsit5 (:mod:`cable_sim.integrate.explicit_adaptive`,
compiled run in :mod:`cable_sim.integrate.erk_run`): tables, order, error control, compiled path.

1. Each table in rational arithmetic against the order conditions written out here (Butcher
   trees up to order 5, Hairer, Norsett & Wanner I, table II.2.2): the propagated weights satisfy
   all 17, the embedded ones the 8 of order <= 4 and not all of order 5 (DOPRI5 exactly; Tsit5's
   16-digit decimal coefficients to 1e-13: measured residuals up to 1.05e-14); the last row
   equals the weights (first-same-as-last).
2. Observed order 5 of the fixed step (the Python reference step) on the order-test cable scene
   with drag off, each end condition, against DOP853 at 1e-13 (with its Morison drag, whose
   ``|v| v`` is not smooth where a velocity changes sign, the order drops below 5 for both pairs:
   measured 2.7-3.5 on the free line).
3. On the paper free fall (n = 80, 31 s) the compiled adaptive run keeps its error near the
   tolerance and shrinks it in proportion when the tolerance shrinks.
4. The compiled run and the Python path take the same steps (up to decisions at round-off) and
   end at the same state; the compiled run reuses the last stage (six force evaluations per
   step) on a free line and not on an anchored one (projected after each step).
"""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest
from order_scenes import ENDS, SMOOTH, dop853_reference, max_joint_position_error, order_case

from cable_sim.integrate import ScipyIntegrator, erk_run, make_integrator
from cable_sim.integrate.explicit_adaptive import erk_step
from cable_sim.scene.scenes import load_scene

HORIZON = 2.0


def _mat(a: list[list[F]]) -> list[list[F]]:
    s = len(a)
    return [list(row) + [F(0)] * (s - len(row)) for row in a]


def _conditions(a: list[list[F]], b: list[F]) -> dict[int, list[tuple[F, F]]]:
    """(value, required) of every order condition up to order 5, by order."""
    A = _mat(a)
    s = len(b)
    one = [F(1)] * s

    def mv(v):  # A v
        return [sum((A[i][j] * v[j] for j in range(s)), F(0)) for i in range(s)]

    def mul(u, v):  # elementwise
        return [x * y for x, y in zip(u, v, strict=True)]

    def bt(v):  # b^T v
        return sum((x * y for x, y in zip(b, v, strict=True)), F(0))

    c = mv(one)
    c2, ac = mul(c, c), mv(c)
    c3, ac2, aac = mul(c2, c), mv(c2), mv(ac)
    return {
        1: [(bt(one), F(1))],
        2: [(bt(c), F(1, 2))],
        3: [(bt(c2), F(1, 3)), (bt(ac), F(1, 6))],
        4: [(bt(c3), F(1, 4)), (bt(mul(c, ac)), F(1, 8)), (bt(ac2), F(1, 12)), (bt(aac), F(1, 24))],
        5: [(bt(mul(c3, c)), F(1, 5)), (bt(mul(c2, ac)), F(1, 10)), (bt(mul(c, ac2)), F(1, 15)),
            (bt(mul(c, aac)), F(1, 30)), (bt(mul(ac, ac)), F(1, 20)), (bt(mv(c3)), F(1, 20)),
            (bt(mv(mul(c, ac))), F(1, 40)), (bt(mv(ac2)), F(1, 60)), (bt(mv(aac)), F(1, 120))],
    }


#: name: (A, b, b_hat, tolerance of the order conditions, stage times as the source lists them)
TABLES = {
    "dopri5": (erk_run.DOPRI5_A, erk_run.DOPRI5_B, erk_run.DOPRI5_B_HAT, F(0),
               [0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0], erk_run.DOPRI5),
    "tsit5": (erk_run.TSIT5_A, erk_run.TSIT5_B, erk_run.TSIT5_B_HAT, F(1, 10**13),
              [0.0, 0.161, 0.327, 0.9, 0.9800255409045097, 1.0, 1.0], erk_run.TSIT5),
}


@pytest.mark.parametrize("name", list(TABLES))
def test_table_orders_5_and_4(name: str) -> None:
    a, b, b_hat, tol, c_listed, tb = TABLES[name]
    prop = _conditions(a, b)
    emb = _conditions(a, b_hat)
    assert sum(len(v) for v in prop.values()) == 17
    for order in range(1, 6):
        assert all(abs(val - req) <= tol for val, req in prop[order]), order
    for order in range(1, 5):
        assert all(abs(val - req) <= tol for val, req in emb[order]), order
    # the estimate is of order 4, not 5
    assert max(abs(val - req) for val, req in emb[5]) > 1e-4
    assert tb.fsal and tb.order == 5 and tb.est_order == 4
    assert np.max(np.abs(tb.c - c_listed)) < 1e-14  # row sums = the listed stage times
    assert abs(tb.e.sum()) < 1e-14  # both weight sets sum to 1


#: Steps of the order test per end condition (the paper's anchor is smoother: larger steps keep its
#: errors well above the reference's).
ORDER_STEPS = {"free": (0.1, 0.05, 0.025), "anchored": (0.1, 0.05, 0.025), "paper_anchor": (0.4, 0.2, 0.1)}


@pytest.mark.parametrize("name", list(TABLES))
@pytest.mark.parametrize("end", list(ENDS))
def test_fixed_step_observed_order_5(end: str, name: str) -> None:
    """Order at least 5 (slope 4.6 .. 6.2: a pair of order 4 would give 4; measured 4.9-5.8,
    the higher values pre-asymptotic)."""
    scene = load_scene("paper_free_fall", {**SMOOTH, **ENDS[end], "anchor_x": 150.0, "anchor_z": -150.0,
                                           "drag_model": "none"})
    model = scene.model()
    y0 = scene.initial_state(model)
    y_ref = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-13, atol=1e-13).advance(
        0.0, y0, HORIZON)
    tab = TABLES[name][-1]
    hs = np.array(ORDER_STEPS[end])
    errs = []
    for h in hs:
        system = scene.system(model=model)
        y = y0.copy()
        for k in range(int(round(HORIZON / h))):
            y = erk_step(system.rhs, k * h, y, float(h), tab)[0]
            if end != "free":  # keep the anchored line on its constraint, as the integrators do
                y = system.project(y)
        errs.append(np.max(np.abs(y - y_ref)))
    errs = np.array(errs)
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    print(f"{name} fixed step {end:13s} errors {np.array2string(errs, precision=2)} -> order {slope:.2f}")
    assert errs[-1] > 1e3 * 1e-13 * np.max(np.abs(y_ref))  # well above the reference's round-off
    assert 4.6 <= slope <= 6.2
    assert np.all(np.diff(errs) < 0)


@pytest.fixture(scope="module")
def free_fall_80():
    scene = load_scene("paper_free_fall", {"n_links": 80, "kernel": "fast", "drag_model": "none"})
    model = scene.model()
    y0 = scene.initial_state(model)
    ref = ScipyIntegrator(scene.system(model=model), "DOP853", rtol=1e-10, atol=1e-10)
    return scene, model, y0, ref.integrate(y0, 0.0, 31.0, 0.5).y


@pytest.mark.parametrize("name", list(TABLES))
def test_adaptive_error_follows_tolerance(free_fall_80, name: str) -> None:
    """Drag off, n = 80, 31 s: at rtol = atol = tol the max joint-position error stays within
    300 tol (measured 8-180 tol over 1e-7 .. 3e-4, largest at 1e-4), a 100x smaller tolerance
    gives an error at least 30x smaller (measured 259x, 384x) and needs more than twice the
    steps (order 5: 100^(1/5) = 2.5)."""
    scene, model, y0, y_ref = free_fall_80
    errs, steps = {}, {}
    for tol in (1e-5, 1e-7):
        integ = make_integrator(name, scene.system(model=model), 0.5, rtol=tol, atol=tol)
        traj = integ.integrate(y0, 0.0, 31.0, 0.5)
        errs[tol] = max_joint_position_error(model, traj.y, y_ref)
        steps[tol] = integ.nsteps
        print(f"{name} tol {tol:g}: error {errs[tol]:.3g} m, {integ.nsteps} steps "
              f"(mean {31e3 / integ.nsteps:.1f} ms), {integ.nrejected} rejected, {integ.nfev} evaluations")
        assert errs[tol] <= 300.0 * tol
        assert integ.nrejected <= 0.1 * integ.nsteps
    assert errs[1e-5] >= 30.0 * errs[1e-7]
    assert steps[1e-7] > 2.0 * steps[1e-5]


@pytest.mark.parametrize("name", list(TABLES))
@pytest.mark.parametrize("end", ["free", "anchored"])
def test_compiled_run_equals_python_path(end: str, name: str) -> None:
    """20 output intervals of 0.1 s under the sine heave force (inputs interpolated inside the
    compiled run): the compiled run and the Python path agree, both match DOP853 to the
    tolerance, and the compiled run's force evaluations are 6 per attempted step plus 1 per
    interval on the free line (the last stage reused), 7 per attempted step when anchored."""
    scene, model, y0 = order_case(end)
    y_ref = dop853_reference(end, HORIZON)
    res = {}
    for kernel in ("fast", "dense"):
        sc = load_scene("paper_free_fall", {**SMOOTH, **ENDS[end], "anchor_x": 150.0, "anchor_z": -150.0,
                                            "kernel": kernel})
        system = sc.system(model=sc.model())
        integ = make_integrator(name, system, 0.1, rtol=1e-7, atol=1e-7)
        assert integ.compiled == (kernel == "fast")
        y = y0
        for k in range(20):
            y = integ.step(0.1 * k, y)
        res[kernel] = (y, integ.nsteps, integ.nrejected, integ.nfev)
    y, nsteps, nrej, nfev = res["fast"]
    err = max_joint_position_error(model, [y], [y_ref])
    print(f"{name} {end} 1e-7 over 20 x 0.1 s: error {err:.3g} m, {nsteps} steps, {nrej} rejected, "
          f"{nfev} evaluations; dense path {res['dense'][1]} steps")
    assert err <= 1e-5
    assert abs(nsteps - res["dense"][1]) <= 2
    assert max_joint_position_error(model, [y], [res["dense"][0]]) <= 1e-7
    attempts = nsteps + nrej
    assert nfev == (6 * attempts + 20 if end == "free" else 7 * attempts)


@pytest.mark.parametrize("name", list(TABLES))
def test_parameters_validated(name: str) -> None:
    scene, model, y0 = order_case("free")
    for kw, match in (({"atol": 0.0}, "atol"), ({"rtol": -1.0}, "rtol"), ({"fac_max": 1.0}, "fac_max"),
                      ({"safety": 0.0}, "safety"), ({"first_step": np.nan}, "first_step")):
        with pytest.raises(ValueError, match=match):
            make_integrator(name, scene.system(model=model), 0.5, **kw)
