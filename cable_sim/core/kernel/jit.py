"""How the hot kernels compile: :data:`HOT_KERNEL`, the numba options of the force evaluation,
the implicit operator's factorisation, solves and products — every compiled function that a step
calls many times and that allocates nothing.

* ``error_model="numpy"``: no division-by-zero branches; a zero divisor gives inf/NaN, which the
  steppers' checks catch.
* ``fastmath={"contract"}``: products and sums fused into FMAs where LLVM chooses (round-off-level
  differences; no assumption about NaN/Inf, which the blow-up detection relies on).
* ``_nrt=False``: no reference counting of the arrays inside. Each array view the kernel forms
  (a workspace row, a model row) and each array handed to an inlined helper otherwise costs a
  call to numba's atomic incref/decref, about a third of a force evaluation at n = 80 (2.37 against
  1.57 us, results equal bit for bit, README "Reference counting out of the hot kernels"). The
  caller owns every array for the duration of the call, so nothing is freed early. Without the
  runtime such a function cannot allocate: an ``np.empty`` in it fails to compile (loud, at the
  first call), so a kernel that needs scratch takes it from its caller's workspace. ``_nrt`` is
  numba's own (underscored) option, tested with numba 0.68.1 (the Makefile's pin).

Core layer, compiled kernel: imports nothing.
"""

from __future__ import annotations

#: numba options of the hot, non-allocating kernels (``nb.njit(**HOT_KERNEL)``).
HOT_KERNEL: dict = {"cache": True, "error_model": "numpy", "fastmath": {"contract"}, "_nrt": False}

__all__ = ["HOT_KERNEL"]
