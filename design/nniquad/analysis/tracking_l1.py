"""The peak-to-peak (L∞ → L∞) gain of a sampled-data loop driven by a continuous input, with its intersample error bounded.

The loop
--------
A hybrid linear system with state ``ζ`` (the continuous plant, the held command and the controller state, all
in one vector): between the sample instants ``kT`` it flows, ``ζ' = A_c ζ + b w(t)``; at each ``kT`` the
controller jumps it, ``ζ(kT⁺) = J ζ(kT⁻)`` (it reads the sampled output, updates its state and holds its new
command over the period).  ``w`` is a scalar continuous-time input with ``|w(t)| <= W`` (a reference's
acceleration or jerk); a row ``r`` is an output ``y = r ζ``.  From rest, ``y(t) = ∫ h(t, τ) w(τ) dτ`` with a
``T``-periodic kernel ``h``, and ``sup_t |y(t)| <= W sup_t ∫ |h(t, τ)| dτ``: this supremum is the gain
:func:`peak_gain` bounds from above (and it is attained by ``w = W sign h(t*, ·)``, so the bound is tight up to
its explicit error terms).

The bound, term by term
-----------------------
Each period is cut into ``n_f`` fine steps of ``δ = T/n_f``; ``t_i = kT + iδ``.

1. **Input inside a fine step.**  Over a step the input enters as ``∫_0^δ φ(σ) w dσ`` with
   ``φ(σ) = e^{A_c(δ-σ)} b``.  Split ``φ = ḡ + (φ - ḡ)``, ``ḡ = g/δ`` its mean, ``g`` the exact
   zero-order-hold input vector: the first part is ``g`` times the step's mean input (at most ``W``), the
   second has norm at most ``W ε``, ``ε = ∫‖φ - ḡ‖ <= κ δ²/2``, ``κ >= max_{q<=δ}‖e^{A_c q} A_c b‖`` (a Taylor
   bound with remainder, :func:`taylor_bound`).  So the kernel's L1 norm over the step, seen through the row
   ``q`` that carries the state at the end of the step to the output, is at most ``|q g| + ε‖q‖₂``.
2. **Past periods.**  A step of an earlier period reaches the next post-jump state through
   ``J e^{A_c(n_f-1-j)δ}``, then the period map ``X = J e^{A_c T}`` ``m`` times, then ``e^{A_c iδ}``.  The sum
   over ``m < M`` is computed; the rest (the tail) is bounded by a Lyapunov certificate: ``P`` solves the
   Stein equation of ``X/ρ₀`` and ``ρ = ‖P^{1/2} X P^{-1/2}‖₂ < 1`` is re-computed, so
   ``|q X^m v| <= ‖q P^{-1/2}‖ ρ^{m-M} ‖P^{1/2} v‖`` for ``m >= M`` and the tail is a geometric series.  ``M``
   grows until the tail is below ``TAIL_RTOL`` of the sum (it is added to the bound, never dropped).
3. **Between the fine instants.**  For ``t = t_i + ρ'``, ``ρ' ∈ [0, δ]``:
   ``y(t) = r e^{A_c ρ'} ζ(t_i) + ∫_{t_i}^t r e^{A_c(t-τ)} b w``, and the Taylor expansion of ``e^{A_c ρ'}`` to
   order ``L`` with its remainder gives
   ``|y(t)| <= Σ_{l<L} δ^l/l! |r A_c^l ζ(t_i)| + δ^L/L! ‖r A_c^L‖ e^{‖A_c‖δ} ‖ζ(t_i)‖ + W δ max_{σ<=δ}|r e^{A_c σ} b|``;
   each ``|r A_c^l ζ(t_i)|`` is bounded by steps 1-2 applied to the row ``r A_c^l`` and
   ``‖ζ(t_i)‖₂ <= Σ_k |ζ_k(t_i)|`` by the unit rows.

The computation runs in the coordinates of a diagonal balancing of ``A_c`` (every step is valid in any
coordinates; balancing keeps ``‖A_c‖δ`` small, so the remainders are negligible).  It is floating point (not
interval arithmetic): rounding is some ``1e-12`` relative, far below the error terms it sits beside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.sampled import zoh
from nniquad.analysis.sampled_lyapunov import conditioning_transform
from nniquad.errors import CascadeError

__all__ = ["HybridLoop", "PeakGain", "peak_gain", "peak_free", "taylor_bound", "FINE_STEPS", "TAYLOR_ORDER", "TAIL_RTOL"]

#: Fine steps per control period (step 1 of the module docstring).
FINE_STEPS: int = 16
#: Order of the Taylor expansions of the intersample bounds (step 3).
TAYLOR_ORDER: int = 8
#: The tail of the sum over past periods is cut when its Lyapunov bound falls below this fraction of the sum.
TAIL_RTOL: float = 1e-6
#: At most this many periods are summed before the Lyapunov tail is taken whatever its size.
MAX_PERIODS: int = 200_000


@dataclass(frozen=True)
class HybridLoop:
    """A sampled-data loop as a hybrid system (module docstring).

    Attributes
    ----------
    A_c : ndarray (n, n)
        Flow between the samples.
    b : ndarray (n,)
        Where the continuous input enters.
    J : ndarray (n, n)
        The jump at each sample instant (the controller's update).
    T
        Sample period [s].
    state_names
        Names of the states of ``ζ``.
    """

    A_c: np.ndarray
    b: np.ndarray
    J: np.ndarray
    T: float
    state_names: tuple[str, ...]

    def row(self, name: str) -> np.ndarray:
        """The unit row reading the state ``name``."""
        r = np.zeros(len(self.state_names))
        r[self.state_names.index(name)] = 1.0
        return r


@dataclass(frozen=True)
class PeakGain:
    """Upper bounds of ``sup_t ∫|h(t, τ)| dτ`` for outputs of a :class:`HybridLoop`.

    Attributes
    ----------
    continuous
        The gain of the continuous output (sup over all ``t``, intersample included).
    held
        The gain of the held output (read at the post-jump instants; constant over each period).
    sampled
        The bound at the fine instants alone (steps 1-2, max over the phases), without the intersample terms of
        step 3: what they add is ``continuous - sampled``.
    contraction
        The Lyapunov contraction factor ``ρ`` of the tail (per period).
    periods
        Periods summed before the tail.
    tail
        The tail's share of ``continuous`` (its Lyapunov bound).
    """

    continuous: float
    held: float
    sampled: float
    contraction: float
    periods: int
    tail: float


def taylor_bound(A: np.ndarray, v: np.ndarray, h: float, order: int = TAYLOR_ORDER) -> float:
    """An upper bound of ``max_{0<=q<=h} ‖e^{A q} v‖₂``, by Taylor with remainder.

    ``e^{Aq} v = Σ_{l<L} q^l/l! A^l v + R``, ``‖R‖ <= q^L/L! ‖A^L v‖ e^{‖A‖q}``.

    Parameters
    ----------
    A
        Square matrix.
    v
        Vector.
    h
        Largest ``q``.
    order
        ``L``.
    """
    total, w = 0.0, np.asarray(v, float)
    for ell in range(order):
        total += h ** ell / math.factorial(ell) * float(np.linalg.norm(w))
        w = A @ w
    return total + h ** order / math.factorial(order) * float(np.linalg.norm(w)) * math.exp(np.linalg.norm(A, 2) * h)


def _balanced(loop: HybridLoop) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(D, A_c, b, J)`` in the coordinates ``ζ = D ζ̂`` of a diagonal balancing of the flow."""
    _, (s, _) = sla.matrix_balance(loop.A_c + np.eye(len(loop.b)), permute=False, separate=True)
    D = np.diag(s)
    Di = np.diag(1.0 / s)
    return D, Di @ loop.A_c @ D, Di @ loop.b, Di @ loop.J @ D


def _tail_certificate(X: np.ndarray) -> tuple[np.ndarray, float]:
    """``(R, ρ)`` with ``‖R X R^{-1}‖₂ = ρ < 1`` (``R = P^{1/2}`` in well-conditioned coordinates; step 2).

    ``P`` solves the Stein equation of ``X/ρ₀`` in the coordinates of
    :func:`nniquad.analysis.sampled_lyapunov.conditioning_transform`; whatever its accuracy, ``ρ`` is re-computed
    from ``R`` and must be below 1.
    """
    sr = float(np.max(np.abs(np.linalg.eigvals(X))))
    if not sr < 1.0:
        raise CascadeError(f"the sampled loop is not stable (spectral radius {sr:.6g}): no tracking bound")
    S = conditioning_transform(X)
    Si = np.linalg.inv(S)
    Xh = Si @ X @ S
    rho0 = sr + 0.25 * (1.0 - sr)
    P = sla.solve_discrete_lyapunov((Xh / rho0).T, np.eye(X.shape[0]))
    P = 0.5 * (P + P.T)
    w, V = np.linalg.eigh(P)
    if not np.all(w > 0):
        raise CascadeError("the tail's Lyapunov matrix is not positive definite")
    R = V @ np.diag(np.sqrt(w)) @ V.T @ Si
    rho = float(np.linalg.norm(R @ X @ np.linalg.inv(R), 2))
    if not rho < 1.0:
        raise CascadeError(f"the tail's Lyapunov certificate does not contract (ρ = {rho:.6g})")
    return R, rho


def peak_gain(loop: HybridLoop, output: np.ndarray, held: np.ndarray | None = None, *, fine_steps: int = FINE_STEPS,
              order: int = TAYLOR_ORDER) -> PeakGain:
    """Bound the peak-to-peak gain from the input to a continuous output and a held output (module docstring).

    Parameters
    ----------
    loop
        The hybrid loop.
    output
        Row of the continuous output (its gain is bounded over every ``t``).
    held
        Row of an output that is constant over each period after the jump (a held command); ``None`` for none.
    fine_steps
        ``n_f``.
    order
        ``L`` of the Taylor expansions.

    Returns
    -------
    PeakGain
    """
    D, A, b, J = _balanced(loop)
    n, T = A.shape[0], loop.T
    delta = T / fine_steps
    r = np.asarray(output, float) @ D
    E1 = sla.expm(A * delta)
    g = zoh(A, b.reshape(-1, 1), delta)[1][:, 0]
    eps = taylor_bound(A, A @ b, delta, order) * delta ** 2 / 2.0
    powers = [np.eye(n)]
    for _ in range(fine_steps):
        powers.append(powers[-1] @ E1)
    X = J @ powers[-1]
    # output rows: the Taylor rows r A^l (l < L), the unit rows (for ‖ζ‖), then the held row
    taylor_rows = [r]
    for _ in range(order - 1):
        taylor_rows.append(taylor_rows[-1] @ A)
    base = np.vstack(taylor_rows + [np.eye(n)] + ([np.asarray(held, float) @ D] if held is not None else []))
    nb = base.shape[0]
    # Q[(row, phase)] = row e^{A iδ}: from the post-jump state to the fine instant t_i
    Q = np.einsum("rk,ikl->ril", base, np.stack(powers[:fine_steps])).reshape(nb * fine_steps, n)
    # inputs of an earlier period, carried to the next post-jump state: v_j = J E1^{n_f-1-j} g, W_j = J E1^{...}
    Wst = np.stack([J @ powers[fine_steps - 1 - j] for j in range(fine_steps)])   # (n_f, n, n)
    V = Wst @ g                                                                  # (n_f, n)
    Wcat = Wst.transpose(1, 0, 2).reshape(n, fine_steps * n)
    # the current period: inputs of steps j < i reach t_i through E1^{i-1-j}
    acc = np.zeros(nb * fine_steps)
    for i in range(1, fine_steps):
        for q in range(i):
            M = base @ powers[q]
            acc[np.arange(nb) * fine_steps + i] += np.abs(M @ g) + eps * np.linalg.norm(M, axis=1)
    Ph, rho = _tail_certificate(X)
    Phi = np.linalg.inv(Ph)
    c_tail = float(np.sum(np.linalg.norm(V @ Ph.T, axis=1))
                   + eps * sum(np.linalg.norm(Ph @ Wst[j], 2) for j in range(fine_steps)))
    m = 0
    while True:
        acc += np.abs(Q @ V.T).sum(axis=1) + eps * np.linalg.norm((Q @ Wcat).reshape(-1, fine_steps, n), axis=2).sum(1)
        Q = Q @ X
        m += 1
        if m % 64 == 0 or m >= MAX_PERIODS:
            tail_vec = np.linalg.norm(Q @ Phi, axis=1) * c_tail / (1.0 - rho)
            if np.max(tail_vec / np.maximum(acc, 1e-300)) < TAIL_RTOL or m >= MAX_PERIODS:
                break
    tot = (acc + tail_vec).reshape(nb, fine_steps)
    tail_share = float(np.max(tail_vec.reshape(nb, fine_steps)[0]))
    L1_taylor, L1_state = tot[:order], tot[order:order + n]
    # step 3: between the fine instants
    coef = np.array([delta ** ell / math.factorial(ell) for ell in range(order)])
    rem = delta ** order / math.factorial(order) * float(np.linalg.norm(taylor_rows[-1] @ A)) \
        * math.exp(np.linalg.norm(A, 2) * delta)
    rb = taylor_rows + [taylor_rows[-1] @ A]
    # the input during [t_i, t]: δ max_σ |r e^{Aσ} b|, by the same Taylor expansion (rem already holds ‖r A^L‖)
    direct = delta * (sum(coef[ell] * abs(float(rb[ell] @ b)) for ell in range(order)) + rem * float(np.linalg.norm(b)))
    cont = coef @ L1_taylor + rem * L1_state.sum(axis=0) + direct
    held_gain = float(tot[-1, 0]) if held is not None else math.nan
    return PeakGain(continuous=float(np.max(cont)), held=held_gain, sampled=float(np.max(L1_taylor[0])),
                    contraction=rho, periods=m, tail=tail_share)


def peak_free(loop: HybridLoop, output: np.ndarray, zeta0: np.ndarray, *, fine_steps: int = FINE_STEPS,
              order: int = TAYLOR_ORDER, held: bool = False) -> float:
    """An upper bound of ``sup_{t>=0} |r ζ(t)|`` of the free response from ``ζ(0⁻) = zeta0`` (the jump at ``t = 0``
    first).

    Between the fine instants as in step 3 of the module docstring; after ``M`` periods
    ``|q X^m y_M| <= ‖q P^{-1/2}‖ ‖P^{1/2} y_M‖`` (``ρ <= 1``) bounds the rest.

    Parameters
    ----------
    loop
        The hybrid loop (its input unused).
    output
        The output row ``r``.
    zeta0
        The state just before the first sample.
    fine_steps, order
        As in :func:`peak_gain`.
    held
        The output is held over each period (read at the post-jump instants only).
    """
    D, A, _, J = _balanced(loop)
    n, T = A.shape[0], loop.T
    delta = T / fine_steps
    r = np.asarray(output, float) @ D
    y = J @ (np.asarray(zeta0, float) / np.diag(D))
    E1 = sla.expm(A * delta)
    powers = [np.eye(n)]
    for _ in range(fine_steps):
        powers.append(powers[-1] @ E1)
    X = J @ powers[-1]
    if held:
        rows, weights = r.reshape(1, -1), np.ones(1)
    else:
        taylor_rows = [r]
        for _ in range(order):
            taylor_rows.append(taylor_rows[-1] @ A)
        coef = [delta ** ell / math.factorial(ell) for ell in range(order)]
        rem = delta ** order / math.factorial(order) * float(np.linalg.norm(taylor_rows[-1])) \
            * math.exp(np.linalg.norm(A, 2) * delta)
        # |r e^{Aρ} ζ| <= Σ coef_l |r A^l ζ| + rem Σ_k |ζ_k|
        rows = np.vstack(taylor_rows[:order] + [np.eye(n)])
        weights = np.concatenate([coef, np.full(n, rem)])
    phases = 1 if held else fine_steps
    Q = np.einsum("rk,ikl->irl", rows, np.stack(powers[:phases]))   # (phases, rows, n)
    Ph, _ = _tail_certificate(X)
    Phi = np.linalg.inv(Ph)
    tail_rows = float(np.max(np.linalg.norm(Q @ Phi, axis=2) @ weights))
    best, m = 0.0, 0
    while True:
        best = max(best, float(np.max(np.abs(Q @ y) @ weights)))
        y = X @ y
        m += 1
        tail = tail_rows * float(np.linalg.norm(Ph @ y))
        if tail < TAIL_RTOL * max(best, 1e-300) or m >= MAX_PERIODS:
            return max(best, tail)
