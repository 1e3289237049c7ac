"""Evaluate a CasADi function at many points straight into numpy arrays.

``fn.map(n)(X, P)`` returns CasADi ``DM`` matrices, and turning a large ``DM``
into numpy goes through a Python list of every element: for the cascade's
Jacobians at thousands of parameter points (millions of entries) that copy
cost more than the evaluation itself.  :func:`evaluate_map` evaluates the same
mapped function through a :class:`casadi.FunctionBuffer` on numpy buffers and
scatters each point's nonzeros into a dense ``(n, rows, cols)`` array: the
same numbers, without the detour.
"""

from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from nniquad.sim.codegen import compile_function

__all__ = ["evaluate_map"]


#: Points per evaluation of the mapped function.  Building ``fn.map(n)`` costs time that grows faster than
#: ``n`` (its output sparsity holds every point's pattern); blocks of this size keep it to milliseconds.
BLOCK = 256


@lru_cache(maxsize=32)
def _block_function(fn: ca.Function, n: int) -> tuple[ca.Function, list[np.ndarray], list[np.ndarray], object]:
    """``fn.map(n)`` compiled to C (:func:`nniquad.sim.codegen.compile_function`, cached on disk like the
    simulator's functions; the CasADi VM without a compiler), with numpy buffers bound to its inputs and outputs,
    and the evaluation callable.  Compiled, the cascade's Jacobians take a fifth of the VM's time, with the same
    numbers (the same operations, in the same order)."""

    fm = compile_function(fn.map(n, "serial"))
    buf, evaluate = fm.buffer()
    ins = [np.zeros(fm.nnz_in(i)) for i in range(fm.n_in())]
    outs = [np.zeros(fm.nnz_out(j)) for j in range(fm.n_out())]
    for i, a in enumerate(ins):
        buf.set_arg(i, memoryview(a))
    for j, a in enumerate(outs):
        buf.set_res(j, memoryview(a))
    return buf, ins, outs, evaluate


def _scatter_index(sp: ca.Sparsity) -> np.ndarray:
    """Column-major linear index of every nonzero of a (per-point) sparsity pattern."""
    return np.asarray(sp.find(), dtype=np.intp)


def evaluate_map(fn: ca.Function, n: int, *args: np.ndarray) -> list[np.ndarray]:
    """``fn`` at ``n`` points: input ``i`` holds one column block per point, outputs are dense per point.

    Parameters
    ----------
    fn
        A CasADi function with dense inputs.
    n
        Number of points.
    *args
        One array per input of shape ``(rows_i, n * cols_i)``: the point
        blocks side by side, as ``fn.map(n)`` takes them.

    Returns
    -------
    list of ndarray
        Output ``j`` as an array ``(n, rows_j, cols_j)``: point ``k``'s value of
        output ``j``, equal to the ``k``-th column block of ``fn.map(n)``'s output.
    """
    n = int(n)
    if len(args) != fn.n_in():
        raise ValueError(f"{fn.name()} takes {fn.n_in()} inputs, got {len(args)}")
    points = []  # per input: (n, nnz per point), each point's column-major values
    for i, a in enumerate(args):
        if not fn.sparsity_in(i).is_dense():
            raise ValueError(f"input {i} of {fn.name()} is not dense")
        rows, cols = fn.size_in(i)
        a = np.asarray(a, dtype=float)
        if a.shape != (rows, n * cols):
            raise ValueError(f"input {i} of {fn.name()} must have shape {(rows, n * cols)}, got {a.shape}")
        points.append(a.reshape(rows, n, cols).transpose(1, 2, 0).reshape(n, rows * cols))
    nnz = [fn.nnz_out(j) for j in range(fn.n_out())]
    values = [np.zeros((n, k)) for k in nnz]
    size = BLOCK  # one compiled block function per fn, whatever n: a short block repeats its last point
    buf, ins, outs, evaluate = _block_function(fn, size)
    for start in range(0, n, size):
        stop = min(start + size, n)
        for src, dst in zip(points, ins):
            block = dst.reshape(size, -1)
            block[: stop - start] = src[start:stop]
            block[stop - start:] = src[stop - 1]  # a short last block repeats its last point
        evaluate()
        if buf.ret() != 0:
            raise RuntimeError(f"evaluation of {fn.name()} failed (return code {buf.ret()})")
        for out, val in zip(outs, values):
            val[start:stop] = out.reshape(size, -1)[: stop - start]  # the map stacks the points' nonzeros
    result = []
    for j, val in enumerate(values):
        sp = fn.sparsity_out(j)
        rows, cols = sp.size()
        dense = np.zeros((n, cols * rows))
        dense[:, _scatter_index(sp)] = val
        result.append(dense.reshape(n, cols, rows).transpose(0, 2, 1))
    return result
