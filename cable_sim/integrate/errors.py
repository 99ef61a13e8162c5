"""Why an integration stops: :class:`IntegrationError` and the compiled steppers' status codes."""

from __future__ import annotations


class IntegrationError(RuntimeError):
    """The integration cannot go on (non-finite state, drifting constraint, failed tolerance).

    Attributes
    ----------
    t : float
        Simulation time [s] at which the failure was detected.
    reason : str
        Human-readable reason.
    """

    def __init__(self, t: float, reason: str) -> None:
        self.t = t
        self.reason = reason
        super().__init__(f"integration failed at t = {t:.6g} s: {reason}")


# status codes of the compiled steppers (cable_sim.core.kernel.STATUS_*)
NONFINITE, DRIFT, TAUT, SINGULAR, ILL, UNSTABLE, ENERGY_JUMP, OSCILLATION = range(1, 9)
