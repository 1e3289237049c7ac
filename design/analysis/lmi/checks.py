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
    "certified_rate",
    "roa_decrease_matrix",
    "roa_inclusion_margin",
    "ellipsoid_level",
]

#: Relative tolerance of every LMI re-check (residuals are divided by the data's scale).
RTOL = 1e-6


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
    M = ni_dissipation_matrix(P, A, B, C)
    return eigmax(M) / max(norm(P) * norm(A), norm(A) * norm(C) * norm(B), norm(C) * norm(B), 1e-300)


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
