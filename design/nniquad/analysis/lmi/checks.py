"""The numpy re-checks: what an LMI answer (or a stored certificate) really certifies.

These functions never call a solver.  The LMI families of this package apply
them to the solver's answer before they report ``feasible=True``, and
:mod:`nniquad.certificates.verify` applies the *same* functions to the matrices
stored in a certificate, so the two can never disagree about what a matrix
proves.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "RTOL",
    "sym",
    "eigmin",
    "eigmax",
    "norm",
    "ni_dissipation_matrix",
    "dissipation_residual",
    "dissipation_scale",
    "certified_rate",
    "roa_decrease_matrix",
    "roa_inclusion_margin",
    "ellipsoid_level",
    "EPS",
    "ROUNDING_SAFETY",
    "scaled_form",
    "definite_margin",
    "contraction_rounding_bound",
    "rate_rounding_bound",
    "expression_rounding_bound",
    "scaled_eig_margin",
    "roa_decrease_margin",
]

#: Relative tolerance of every LMI re-check (residuals are divided by the data's scale).
RTOL = 1e-6
#: Unit roundoff of the float64 arithmetic every re-check runs in (machine epsilon).
EPS: float = float(np.finfo(np.float64).eps)
#: Factor on the first-order rounding bounds below (:func:`definite_margin`, :func:`contraction_rounding_bound`,
#: :func:`rate_rounding_bound`, :func:`expression_rounding_bound`): an order of magnitude over the constants
#: of the backward-error analyses they stand on (Cholesky, symmetric eigenvalues, matrix products), so that a
#: strict inequality certified with a margin above the bound holds whatever BLAS kernel, thread count or
#: summation order another machine uses.
ROUNDING_SAFETY: float = 10.0


def sym(M: np.ndarray) -> np.ndarray:
    """Symmetric part ``(M + M^T)/2``."""
    return 0.5 * (M + M.T)


def eigmin(M: np.ndarray) -> float:
    """Smallest eigenvalue of the symmetric part of ``M``."""
    return float(np.linalg.eigvalsh(sym(M))[0])


def eigmax(M: np.ndarray) -> float:
    """Largest eigenvalue of the symmetric part of ``M``."""
    return float(np.linalg.eigvalsh(sym(M))[-1])


def norm(*Ms: np.ndarray) -> float:
    """Largest spectral norm of the matrices."""
    return max(float(np.linalg.norm(M, 2)) for M in Ms)


def ni_dissipation_matrix(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """``[[PA + A^T P, PB - A^T C^T], [B^T P - CA, -(CB + B^T C^T)]]``.

    ``dV/dt - ydot^T u = [x; u]^T M [x; u] / 2`` for ``V = x^T P x / 2``; the NI
    dissipation inequality holds iff this matrix is negative semidefinite.

    Parameters
    ----------
    P
        Storage matrix (n x n).
    A, B, C
        The system ``x' = Ax + Bu``, ``y = Cx``.
    """
    top = np.hstack([P @ A + A.T @ P, P @ B - A.T @ C.T])
    bottom = np.hstack([B.T @ P - C @ A, -(C @ B + B.T @ C.T)])
    return np.vstack([top, bottom])


def dissipation_residual(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> float:
    """Largest eigenvalue of :func:`ni_dissipation_matrix`, relative to its scale.

    ``<= ~0`` (within the tolerance) iff ``V = x^T P x / 2`` satisfies the NI
    inequality ``dV/dt <= ydot^T u``; ``P > 0`` must be checked separately.

    Parameters
    ----------
    P
        Storage matrix.
    A, B, C
        The system.
    """
    return eigmax(ni_dissipation_matrix(P, A, B, C)) / dissipation_scale(P, A, B, C)


def dissipation_scale(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> float:
    """The scale :func:`dissipation_residual` is relative to: the largest norm product of its terms."""
    return max(norm(P) * norm(A), norm(A) * norm(C) * norm(B), norm(C) * norm(B), 1e-300)


def certified_rate(A: np.ndarray, P: np.ndarray) -> float:
    """The decay rate a given ``P`` certifies for ``A`` (scale-free); ``-inf`` unless ``P > 0``.

    The largest eps with ``A'P + PA <= -eps P`` is ``-lambda_max(L^{-1}(A'P + PA)L^{-T})``
    with ``P = L L'`` (a generalised symmetric eigenvalue problem).

    Parameters
    ----------
    A
        System matrix.
    P
        Candidate Lyapunov matrix (its symmetric part is used).
    """
    P = sym(P)
    if np.min(np.linalg.eigvalsh(P)) <= 0:
        return -math.inf
    Li = np.linalg.inv(np.linalg.cholesky(P))
    return -eigmax(Li @ (A.T @ P + P @ A) @ Li.T)


def roa_decrease_matrix(A_cl: np.ndarray, B: np.ndarray, P: np.ndarray, G: np.ndarray, T: np.ndarray) -> np.ndarray:
    """S-procedure matrix of the saturated loop, in the original variables ``(P, G, T)``.

    ``[[A_cl'P + P A_cl, -P B + G'T], [-B'P + T G, -2T]]``: negative definite iff
    ``V = x'Px`` decreases along ``x' = A_cl x - B psi`` whenever the generalised
    sector condition ``psi'T(psi - G x) <= 0`` holds.

    Parameters
    ----------
    A_cl, B
        Closed loop and the saturation input (``x' = A_cl x - B psi(Kx)``).
    P
        Ellipsoid matrix.
    G, T
        Sector-condition multipliers (1 x n and 1 x 1).
    """
    return np.block([[A_cl.T @ P + P @ A_cl, -P @ B + G.T @ T], [-B.T @ P + T @ G, -2 * T]])


def roa_inclusion_margin(K: np.ndarray, G: np.ndarray, W: np.ndarray, u0: float) -> float:
    """``(u0^2 - (K - G) W (K - G)') / u0^2``: ``>= 0`` iff ``{x'W^{-1}x <= 1}`` lies where ``|(K - G)x| <= u0``.

    Parameters
    ----------
    K
        Acceleration command row (1 x n).
    G
        Sector multiplier (1 x n).
    W
        Inverse of the ellipsoid matrix P.
    u0
        Acceleration limit (m/s^2).
    """
    return float(u0**2 - ((K - G) @ W @ (K - G).T)[0, 0]) / u0**2


def ellipsoid_level(P: np.ndarray, x0: np.ndarray) -> float:
    """``x0' P x0``: the start state ``x0`` lies in the certified ellipsoid iff this is ``<= 1``.

    Parameters
    ----------
    P
        Ellipsoid matrix.
    x0
        State (column or flat vector).
    """
    x = np.asarray(x0, dtype=float).reshape(-1, 1)
    return float((x.T @ P @ x)[0, 0])


# ----------------------------------------------------------------------------- rounding bounds of strict inequalities
#
# A strict inequality (rho < 1, P > 0, a decrease) is certified only with a margin above what rounding can move the
# computed number: another machine (another OpenBLAS kernel, thread count or summation order) computes the same
# quantity with a different rounding error, of at most these first-order bounds.  Definiteness and contraction are
# invariant under a diagonal congruence, and Cholesky's and the symmetric eigensolver's errors depend on the
# diagonally scaled matrix (van der Sluis; Demmel, SIAM J. Matrix Anal. Appl. 1989), so the bounds use
# ``P_s = D^-1/2 P D^-1/2`` with ``D = diag(P)``: a block-diagonal P of blocks in different units is not penalised
# for its unscaled condition number (about 1e16 for the 19-state cascade, against 3e8 scaled).


def scaled_form(P: np.ndarray, A: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """``P_s = D^-1/2 P D^-1/2`` (unit diagonal) and ``A_s = D^1/2 A D^-1/2``, ``D = diag(P)``; stacks allowed.

    The contraction ``||P^1/2 A P^-1/2||`` and the definiteness of ``P`` are the same for ``(P_s, A_s)``.
    A non-positive diagonal gives ``nan`` entries (``P`` is then not positive definite).

    Parameters
    ----------
    P : array (..., n, n)
        Symmetric matrix (its symmetric part is used).
    A : array (..., n, n), optional
        A system matrix in the same coordinates.
    """
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    diag = np.diagonal(P, axis1=-2, axis2=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(np.where(diag > 0, diag, np.nan))
        Ps = P / d[..., :, None] / d[..., None, :]
        As = None if A is None else A * d[..., :, None] / d[..., None, :]
    return Ps, As


def definite_margin(P: np.ndarray) -> tuple[np.ndarray | float, np.ndarray | float]:
    """``(lambda_min(P_s), bound)``: ``P > 0`` is certified iff the first exceeds the second.

    ``bound = ROUNDING_SAFETY * n * EPS * ||P_s||_2`` bounds the error of a backward-stable symmetric eigensolver
    on the scaled matrix (Weyl).  Works on a stack ``(..., n, n)``; a non-positive diagonal gives ``(-inf, bound)``.

    Parameters
    ----------
    P
        Symmetric matrix or stack of them.
    """
    Ps, _ = scaled_form(np.asarray(P, dtype=float))
    n = Ps.shape[-1]
    finite = np.all(np.isfinite(Ps), axis=(-2, -1))
    ev = np.linalg.eigvalsh(np.where(finite[..., None, None], Ps, 0.0))
    lam_min = np.where(finite, ev[..., 0], -np.inf)
    bound = ROUNDING_SAFETY * n * EPS * np.where(finite, np.max(np.abs(ev), axis=-1), 1.0)
    if np.ndim(lam_min) == 0:
        return float(lam_min), float(bound)
    return lam_min, bound


def contraction_rounding_bound(A: np.ndarray, P: np.ndarray, rho: np.ndarray | float) -> np.ndarray | float:
    """Bound on the rounding error of the contraction ``rho = ||P^1/2 A P^-1/2||_2`` computed in float64.

    ``ROUNDING_SAFETY * n * EPS * (kappa_s rho + sqrt(kappa_s) ||A_s||_2)`` with ``kappa_s`` the condition
    number of the scaled ``P_s`` and ``A_s`` the scaled ``A`` (:func:`scaled_form`): the first term is the change
    of the ``P``-norm under Cholesky's backward error (``|x' dP x| / x'Px <= ||dP_s|| / lambda_min(P_s)``), the
    second the error of forming ``L' A L^-T``.  ``rho < 1`` is certified iff ``1 - rho`` exceeds it.
    Works on stacks (``A``, ``P`` of shape ``(..., n, n)``, ``rho`` of shape ``(...)``).

    Parameters
    ----------
    A, P
        System and Lyapunov matrices (or stacks).
    rho
        The computed contraction(s).
    """
    Ps, As = scaled_form(np.asarray(P, dtype=float), np.asarray(A, dtype=float))
    n = Ps.shape[-1]
    ev = np.linalg.eigvalsh(np.nan_to_num(Ps, nan=0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(ev[..., 0] > 0, ev[..., -1] / ev[..., 0], np.inf)
    norm_a = np.linalg.norm(np.nan_to_num(As, nan=0.0), 2, axis=(-2, -1))
    out = ROUNDING_SAFETY * n * EPS * (kappa * np.abs(rho) + np.sqrt(kappa) * norm_a)
    return float(out) if np.ndim(out) == 0 else out


def rate_rounding_bound(A: np.ndarray, P: np.ndarray, rate: float) -> float:
    """Bound on the rounding error of :func:`certified_rate` (the decay ``eps`` with ``A'P + PA <= -eps P``).

    ``ROUNDING_SAFETY * n * EPS * kappa_s (|rate| + 2 ||A_s||_2)``: the rate is ``-lambda_max`` of
    ``L^-1 (A'P + PA) L^-T``, whose scaled form has norm at most ``2 kappa_s ||A_s||``, plus the change of the
    ``P``-norm under Cholesky's backward error.  A decay ``rate > 0`` is certified iff it exceeds the bound.

    Parameters
    ----------
    A, P
        System and Lyapunov matrix.
    rate
        The computed rate [1/s].
    """
    Ps, As = scaled_form(np.asarray(P, dtype=float), np.asarray(A, dtype=float))
    if not np.all(np.isfinite(Ps)):
        return math.inf
    ev = np.linalg.eigvalsh(Ps)
    if ev[0] <= 0:
        return math.inf
    kappa = float(ev[-1] / ev[0])
    n = Ps.shape[-1]
    return ROUNDING_SAFETY * n * EPS * kappa * (abs(float(rate)) + 2.0 * float(np.linalg.norm(As, 2)))


def expression_rounding_bound(n: int, *product_norms: float) -> float:
    """Bound on the eigenvalue error of a symmetric matrix expression ``sum_i X_i Y_i Z_i`` formed in float64.

    ``ROUNDING_SAFETY * n * EPS * sum ||X_i|| ||Y_i|| ||Z_i||`` (products and sums, then a backward-stable
    eigensolver): a strict ``lambda_max < 0`` is certified iff ``-lambda_max`` exceeds it.

    Parameters
    ----------
    n
        Dimension of the expression.
    product_norms
        The norm product of every term (``||X|| ||Y|| ||Z||``).
    """
    return ROUNDING_SAFETY * int(n) * EPS * float(sum(abs(float(v)) for v in product_norms))


def scaled_eig_margin(M: np.ndarray, M_abs: np.ndarray, n_inner: int) -> tuple[float, float]:
    """``(lambda_max(D M D), bound)``, ``D = |diag M|^-1/2``: a strict ``M < 0`` is certified iff the first is below
    minus the second.

    ``M_abs`` is the same expression formed from the absolute values of its factors, so that the float64 error of
    every entry of ``M`` is at most ``n_inner * EPS * M_abs`` (componentwise, first order);
    ``bound = ROUNDING_SAFETY * n_inner * EPS * ||D M_abs D||_2`` plus the eigensolver's own error.  The diagonal
    congruence keeps the sign of every eigenvalue and takes away the states' units, so that a decrease is judged
    on its own scale, not on the largest entry's.

    Parameters
    ----------
    M
        The symmetric expression.
    M_abs
        The expression formed from the absolute values of its factors.
    n_inner
        The longest inner dimension of its products.
    """
    M = sym(np.asarray(M, dtype=float))
    diag = np.abs(np.diag(M))
    d = 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0))
    Ms = M * d[:, None] * d[None, :]
    Es = np.abs(np.asarray(M_abs, dtype=float)) * d[:, None] * d[None, :]
    lam = float(np.linalg.eigvalsh(Ms)[-1])
    bound = ROUNDING_SAFETY * EPS * (int(n_inner) * float(np.linalg.norm(Es, 2)) + M.shape[0] * float(norm(Ms)))
    return lam, bound


def roa_decrease_margin(A_cl: np.ndarray, B: np.ndarray, P: np.ndarray, G: np.ndarray,
                        T: np.ndarray) -> tuple[float, float]:
    """``(lambda_max, bound)`` of the diagonally scaled :func:`roa_decrease_matrix` (:func:`scaled_eig_margin`).

    The decrease is strict (``V' < 0`` off the origin), so it is certified iff ``lambda_max < -bound``.

    Parameters
    ----------
    A_cl, B, P, G, T
        As in :func:`roa_decrease_matrix`.
    """
    M = roa_decrease_matrix(A_cl, B, P, G, T)
    M_abs = roa_decrease_matrix(np.abs(A_cl), np.abs(B), np.abs(P), np.abs(G), np.abs(T))
    # |-P B + G'T| <= |P||B| + |G'||T|: the sign flips of the off-diagonal block do not lower the bound
    n = A_cl.shape[0]
    M_abs[:n, n:] = np.abs(P) @ np.abs(B) + np.abs(G).T @ np.abs(T)
    M_abs[n:, :n] = M_abs[:n, n:].T
    return scaled_eig_margin(M, M_abs, n + 1)
