"""A CasADi function called through its buffer: numbers in and out of numpy arrays bound
once, with no ``casadi.DM`` built per call.

Calling a ``casadi.Function`` from Python converts every numpy argument to a ``DM`` and every
result back, through SWIG. For the planner's small NLP these conversions cost more than the
solve: measured on the ``paper`` preset's warm starts, ``ca.DM`` of the 12 increments takes
about 55 us and of the parameters about 80 us, a whole ``solver.call`` 180 us, against 75 us
for the same SQP solve through the buffer (``Function.buffer()``, casadi >= 3.6).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["BufferedFunction"]


class BufferedFunction:
    """``fn`` with one dense float array per input (:attr:`inputs`) and per output
    (:attr:`outputs`), bound to its buffer once.

    Every input must be set: an input left unbound reads as zeros (an NLP's bounds too).
    ``share`` binds the given inputs to existing arrays (two functions reading one parameter
    vector). The outputs are overwritten by the next call: copy what must outlive it.
    Matrices are stored column by column (CasADi's order); :meth:`output` reshapes."""

    def __init__(self, fn: ca.Function, share: dict[int, np.ndarray] | None = None):
        for i in range(fn.n_in()):
            if not fn.sparsity_in(i).is_dense():
                raise ValueError(f"{fn.name()}: input {fn.name_in(i)!r} is not dense")
        for i in range(fn.n_out()):
            if not fn.sparsity_out(i).is_dense():
                raise ValueError(f"{fn.name()}: output {fn.name_out(i)!r} is not dense")
        share = share or {}
        self.fn = fn
        self.inputs = [share[i] if i in share else np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
        for i, a in enumerate(self.inputs):
            if a.dtype != np.float64 or a.ndim != 1 or not a.flags.c_contiguous or a.size != fn.nnz_in(i):
                raise ValueError(f"{fn.name()}: the array for input {fn.name_in(i)!r} must be a contiguous float "
                                 f"vector of {fn.nnz_in(i)}")
        self.outputs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        self._buf, self._eval = fn.buffer()
        for i, a in enumerate(self.inputs):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate(self.outputs):
            self._buf.set_res(i, memoryview(a))

    def __call__(self, *args) -> int:
        """Copy ``args`` into the inputs (``None``: keep what is there) and evaluate; the
        function's return flag (0: no error reported)."""
        for a, x in zip(self.inputs, args):
            if x is not None:
                a[:] = np.ravel(x, order="F")
        self._eval()
        return self._buf.ret()

    def output(self, i: int) -> np.ndarray:
        """A copy of output ``i`` in its shape."""
        return self.outputs[i].reshape(self.fn.size_out(i), order="F").copy()

    def fork(self) -> "BufferedFunction":
        """A second buffer of the same function: its own CasADi memory and arrays, the inputs
        copied (the constant ones stay set). CasADi releases the GIL while a buffer
        evaluates, so two buffers can run in two threads at once
        (:mod:`casadi_gpc.planner.lanes`)."""
        twin = BufferedFunction(self.fn)
        for a, b in zip(twin.inputs, self.inputs):
            a[:] = b
        return twin

    def stats(self) -> dict:
        """The function's statistics of the last call through this buffer (an NLP solver's
        ``success``, ``return_status``, ``iter_count``)."""
        return self._buf.stats()
