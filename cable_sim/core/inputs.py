"""Built-in input signals: constant, sine, regular wave and irregular sea states (JONSWAP).

Each signal is a callable ``signal(t) -> float`` (t in s). They are pure functions of time,
so a run driven by them is reproducible, and a recorded run can be re-simulated exactly.
Each also has a packed form, ``signal.packed()`` (a small float array), that the compiled
steppers evaluate inside their loop with the same arithmetic
(:mod:`cable_sim.core.kernel.signals`; imported lazily, so the dense path needs no compiler).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cable_sim.core.params import ParameterError

SOURCES = ("none", "topic", "constant", "sine", "regular_wave", "jonswap")


def _ramp(t: float, ramp: float) -> float:
    """Smooth 0 -> 1 ramp over ``ramp`` seconds (half-cosine); 1 if ramp <= 0."""
    if ramp <= 0.0 or t >= ramp:
        return 1.0
    if t <= 0.0:
        return 0.0
    return 0.5 * (1.0 - np.cos(np.pi * t / ramp))


@dataclass(frozen=True)
class Constant:
    """Constant value."""

    value: float = 0.0

    def __call__(self, t: float) -> float:
        return self.value

    def packed(self) -> np.ndarray:
        """The packed form ``[0, 0, 0, value]`` (see :mod:`cable_sim.core.kernel.signals`)."""
        from cable_sim.core.kernel.signals import CONSTANT, pack_signal

        return pack_signal(CONSTANT, 0.0, self.value)


@dataclass(frozen=True)
class Sine:
    """``amplitude * sin(2 pi t / period + phase)`` with an optional start ramp [s]."""

    amplitude: float
    period: float
    phase: float = 0.0
    ramp: float = 0.0

    def __call__(self, t: float) -> float:
        return _ramp(t, self.ramp) * self.amplitude * np.sin(2 * np.pi * t / self.period + self.phase)

    def packed(self) -> np.ndarray:
        """The packed form: one (amplitude, period, phase) term of kind ``SINE`` (see
        :mod:`cable_sim.core.kernel.signals`)."""
        from cable_sim.core.kernel.signals import SINE, pack_signal

        return pack_signal(SINE, self.ramp, 0.0, [[self.amplitude, self.period, self.phase]])


class Jonswap:
    """Irregular sea surface elevation from a JONSWAP spectrum (random phases, fixed seed).

    Parameters
    ----------
    hs : float
        Significant wave height H_s [m].
    tp : float
        Peak period T_p [s].
    gamma : float
        Peak enhancement factor (3.3 is the North Sea default; 1 gives Pierson-Moskowitz).
    seed : int
        Seed of the random phases, so a sea state is reproducible.
    n_components : int
        Number of harmonic components (equal frequency spacing between 0.5 and 3 omega_p... up
        to 4 omega_p).
    ramp : float
        Start ramp [s].
    """

    def __init__(
        self, hs: float, tp: float, gamma: float = 3.3, seed: int = 0, n_components: int = 128,
        ramp: float = 0.0,
    ) -> None:
        if hs < 0:
            raise ParameterError("wave_hs", hs, "a number >= 0")
        if tp <= 0:
            raise ParameterError("wave_tp", tp, "a number > 0")
        if gamma < 1:
            raise ParameterError("wave_gamma", gamma, "a number >= 1")
        wp = 2 * np.pi / tp
        w = np.linspace(0.4 * wp, 4.0 * wp, n_components)
        dw = w[1] - w[0]
        self.omega = w
        self.spectrum = jonswap_spectrum(w, hs, tp, gamma)
        self.amplitude = np.sqrt(2.0 * self.spectrum * dw)
        self.phase = np.random.default_rng(seed).uniform(0, 2 * np.pi, n_components)
        self.ramp = ramp

    def __call__(self, t: float) -> float:
        return _ramp(t, self.ramp) * float(np.sum(self.amplitude * np.cos(self.omega * t + self.phase)))

    def packed(self) -> np.ndarray:
        """The packed form: (amplitude, omega, phase) terms of kind ``COSINE_SUM`` (see
        :mod:`cable_sim.core.kernel.signals`)."""
        from cable_sim.core.kernel.signals import COSINE_SUM, pack_signal

        terms = np.column_stack([self.amplitude, self.omega, self.phase])
        return pack_signal(COSINE_SUM, self.ramp, 0.0, terms)


def jonswap_spectrum(omega: np.ndarray, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """One-sided JONSWAP spectral density S(omega) [m^2 s/rad] (DNV-RP-C205 form).

    Normalised with the factor 1 - 0.287 ln(gamma) so that 4 sqrt(m0) ~= H_s.
    """
    wp = 2 * np.pi / tp
    sigma = np.where(omega <= wp, 0.07, 0.09)
    pm = 5.0 / 16.0 * hs**2 * wp**4 * omega**-5.0 * np.exp(-1.25 * (omega / wp) ** -4)
    return (1 - 0.287 * np.log(gamma)) * pm * gamma ** np.exp(-0.5 * ((omega - wp) / (sigma * wp)) ** 2)


def make_signal(kind: str, prefix: str, cfg: dict) -> Constant | Sine | Jonswap:
    """Build a signal from scene keys ``<prefix>_amplitude``, ``<prefix>_period``, ...

    ``none`` and ``topic`` give a zero signal (the ROS node overrides ``topic``).
    """
    if kind not in SOURCES:
        raise ParameterError(f"{prefix}_source", kind, "one of " + ", ".join(SOURCES))
    get = lambda k, d: float(cfg.get(f"{prefix}_{k}", d))  # noqa: E731
    if kind in ("none", "topic"):
        return Constant(0.0)
    if kind == "constant":
        return Constant(get("value", 0.0))
    if kind in ("sine", "regular_wave"):
        period = get("period", 10.0)
        if period <= 0:
            raise ParameterError(f"{prefix}_period", period, "a number > 0")
        return Sine(get("amplitude", 0.0), period, get("phase", 0.0), get("ramp", 0.0))
    return Jonswap(get("hs", 2.0), get("tp", 10.0), get("gamma", 3.3), int(get("seed", 0)),
                   ramp=get("ramp", 0.0))
