"""Rainflow cycle counting (ASTM E1049-85, sec. 5.4.4) and Miner fatigue damage with a T-N curve.

T-N curve (DNV-OS-E301, Ch.2 Sec.2, fatigue limit state)::

    n_c(s) = a_D * s**(-m)

with ``n_c`` the number of cycles to failure at the stress range ``s`` [MPa] (double amplitude),
``s = tension range / nominal area``. Nominal area: a chain link has two legs, A = 2 pi d^2 / 4;
a wire rope A = pi d^2 / 4 (d the nominal diameter). Default curves (DNV-OS-E301 table
"Parameters for T-N curves", values as commonly quoted from the standard):

=====================  =========  =====
component              a_D        m
=====================  =========  =====
studless chain         6.0e10     3.0
stud chain             1.2e11     3.0
six-strand rope        3.4e14     4.0
spiral-strand rope     1.7e17     4.8
=====================  =========  =====

Miner's rule: D = sum_i n_i / n_c(s_i) with n_i = 1 for a full cycle and 0.5 for a half cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cable_sim.core.params import ParameterError

#: (a_D, m, legs) per component type; legs = 2 for chain (two legs per link), 1 for rope.
TN_DEFAULTS: dict[str, tuple[float, float, int]] = {
    "studless_chain": (6.0e10, 3.0, 2),
    "stud_chain": (1.2e11, 3.0, 2),
    "six_strand_rope": (3.4e14, 4.0, 1),
    "spiral_rope": (1.7e17, 4.8, 1),
}


@dataclass(frozen=True)
class TNCurve:
    """A T-N curve ``n_c = a_d * s**-m`` with the stress range ``s`` in MPa.

    Attributes
    ----------
    kind : str
        Component type (a key of :data:`TN_DEFAULTS`, or ``custom``).
    a_d : float
        Intercept a_D.
    m : float
        Slope m.
    area : float or None
        Nominal area [m^2] dividing the tension range; None: use the scene's ``diameter``
        with the component's number of legs (see :meth:`nominal_area`).
    legs : int
        2 for chain, 1 for rope.
    """

    kind: str
    a_d: float
    m: float
    area: float | None
    legs: int

    def nominal_area(self, scene_diameter: float) -> float:
        """Nominal area [m^2]: the given one, else legs * pi d^2 / 4 with the scene's diameter."""
        if self.area is not None:
            return self.area
        return self.legs * math.pi * float(scene_diameter) ** 2 / 4.0

    def as_dict(self) -> dict[str, float | str | int | None]:
        """Plain mapping (for rows and pickling)."""
        return {"kind": self.kind, "a_d": self.a_d, "m": self.m, "area": self.area, "legs": self.legs}


def tn_curve_from_dict(d: dict) -> TNCurve:
    """T-N curve from a study's ``tn_curve`` section.

    Keys: ``type`` (default ``studless_chain``; one of :data:`TN_DEFAULTS` or ``custom``),
    ``a_d`` and ``m`` (override the defaults; required for ``custom``), ``nominal_diameter`` [m]
    or ``area`` [m^2] (default: the scene's ``diameter`` with 2 legs for chain, 1 for rope).
    """
    if not isinstance(d, dict):
        raise ParameterError("tn_curve", d, "a mapping with type, a_d, m, nominal_diameter or area")
    allowed = {"type", "a_d", "m", "nominal_diameter", "area"}
    for k in d:
        if k not in allowed:
            raise ParameterError(f"tn_curve.{k}", d[k], "one of " + ", ".join(sorted(allowed)))
    kind = d.get("type", "studless_chain")
    if kind not in TN_DEFAULTS and kind != "custom":
        raise ParameterError("tn_curve.type", kind, "one of " + ", ".join([*TN_DEFAULTS, "custom"]))
    a_d, m, legs = TN_DEFAULTS.get(kind, (None, None, 1))
    a_d = d.get("a_d", a_d)
    m = d.get("m", m)
    for key, v in (("a_d", a_d), ("m", m)):
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
            raise ParameterError(f"tn_curve.{key}", v, "a finite number > 0")
    area = d.get("area")
    if "nominal_diameter" in d:
        dn = d["nominal_diameter"]
        if not isinstance(dn, (int, float)) or not math.isfinite(dn) or dn <= 0:
            raise ParameterError("tn_curve.nominal_diameter", dn, "a finite number > 0 [m]")
        area = legs * math.pi * float(dn) ** 2 / 4.0
    if area is not None and (not isinstance(area, (int, float)) or not math.isfinite(area) or area <= 0):
        raise ParameterError("tn_curve.area", area, "a finite number > 0 [m^2]")
    return TNCurve(str(kind), float(a_d), float(m), None if area is None else float(area), legs)


def turning_points(x: np.ndarray) -> np.ndarray:
    """Reversals of ``x``: first and last samples and every local extremum (plateaus collapsed)."""
    x = np.asarray(x, dtype=float)
    if x.size < 2:
        return x.copy()
    keep = np.concatenate([[True], np.diff(x) != 0])
    y = x[keep]
    if y.size < 3:
        return y
    d = np.diff(y)
    rev = np.sign(d[1:]) != np.sign(d[:-1])
    return np.concatenate([[y[0]], y[1:-1][rev], [y[-1]]])


def rainflow_cycles(x: np.ndarray) -> list[tuple[float, float, float]]:
    """Rainflow count by ASTM E1049-85 sec. 5.4.4 (three-point method with half cycles).

    Parameters
    ----------
    x : array_like
        Load history.

    Returns
    -------
    list of (range, mean, count)
        ``count`` is 1.0 for a full cycle and 0.5 for a half cycle.
    """
    stack: list[float] = []
    out: list[tuple[float, float, float]] = []
    for p in turning_points(x):
        stack.append(float(p))
        while len(stack) >= 3:
            X = abs(stack[-1] - stack[-2])
            Y = abs(stack[-2] - stack[-3])
            if X < Y:
                break
            if len(stack) == 3:  # Y contains the starting point: a half cycle, drop the start
                out.append((Y, 0.5 * (stack[0] + stack[1]), 0.5))
                stack.pop(0)
            else:  # a full cycle Y: remove its two points
                out.append((Y, 0.5 * (stack[-3] + stack[-2]), 1.0))
                last = stack.pop()
                del stack[-2:]
                stack.append(last)
    for a, b in zip(stack[:-1], stack[1:], strict=False):  # residue: half cycles
        out.append((abs(b - a), 0.5 * (a + b), 0.5))
    return out


def miner_damage(tension: np.ndarray, curve: TNCurve, area: float) -> float:
    """Miner damage of a tension history [N] on a T-N curve, the range normalised by ``area`` [m^2].

    ``s = range / area / 1e6`` [MPa]; D = sum count * s**m / a_D.
    """
    cyc = rainflow_cycles(tension)
    if not cyc:
        return 0.0
    rng = np.array([c[0] for c in cyc]) / area / 1e6
    cnt = np.array([c[2] for c in cyc])
    return float(np.sum(cnt * rng**curve.m) / curve.a_d)


__all__ = ["TNCurve", "TN_DEFAULTS", "tn_curve_from_dict", "turning_points", "rainflow_cycles",
           "miner_damage"]
