"""A small affine-LMI problem handed to Clarabel directly (no modelling layer).

The region-of-attraction LMI has a few hundred decision variables and a few
hundred small matrix inequalities; cvxpy's canonicalisation of it takes 20-80 s,
Clarabel's solve about 3 s.  Here every constraint is given by its numeric
coefficient matrices, ``F_0 + Σ_j z_j F_j ⪰ 0``, built with numpy.  The solver's
answer proves nothing by itself: every caller re-checks it with numpy.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

__all__ = ["ConicProblem", "svec", "sym_basis"]


def _svec_index(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and weights of Clarabel's packing of a symmetric ``k × k`` matrix (upper triangle by columns,
    off-diagonal entries times ``√2``, so that the packing is an isometry)."""
    pairs = [(i, j) for j in range(k) for i in range(j + 1)]
    r = np.array([i for i, _ in pairs], int)
    c = np.array([j for _, j in pairs], int)
    return r, c, np.where(r == c, 1.0, math.sqrt(2.0))


def sym_basis(n: int) -> np.ndarray:
    """The symmetric unit matrices ``E_ij + E_ji`` (``i <= j``; ``E_ii`` on the diagonal), ``(n (n+1)/2, n, n)``:
    a symmetric matrix variable is ``Σ_e z_e E_e``."""
    idx = [(i, j) for j in range(n) for i in range(j + 1)]
    E = np.zeros((len(idx), n, n))
    for t, (i, j) in enumerate(idx):
        E[t, i, j] = E[t, j, i] = 1.0
    return E


def svec(S: np.ndarray) -> np.ndarray:
    """Clarabel's packing of symmetric matrices ``(..., k, k) -> (..., k (k + 1) / 2)``."""
    r, c, w = _svec_index(S.shape[-1])
    return S[..., r, c] * w


@dataclass
class ConicProblem:
    """``minimise cᵀ z`` subject to equalities, inequalities and matrix inequalities affine in ``z``.

    Attributes
    ----------
    n
        Number of decision variables so far.
    """

    n: int = 0
    _eq: list = field(default_factory=list)
    _nn: list = field(default_factory=list)
    _psd: list = field(default_factory=list)

    def variables(self, count: int) -> np.ndarray:
        """Indices of ``count`` new decision variables."""
        idx = np.arange(self.n, self.n + int(count))
        self.n += int(count)
        return idx

    def equal(self, g0: np.ndarray, idx: np.ndarray, gz: np.ndarray) -> None:
        """``g0 + gz z[idx] = 0`` (``g0 (N,)``, ``gz (N, len(idx))``)."""
        self._eq.append((np.asarray(g0, float), np.asarray(idx), np.asarray(gz, float)))

    def nonnegative(self, g0: np.ndarray, idx: np.ndarray, gz: np.ndarray) -> None:
        """``g0 + gz z[idx] >= 0`` (``g0 (N,)``, ``gz (N, len(idx))``)."""
        self._nn.append((np.asarray(g0, float), np.asarray(idx), np.asarray(gz, float)))

    def psd(self, F0: np.ndarray, idx: np.ndarray, Fz: np.ndarray) -> None:
        """``F0[i] + Σ_j z[idx[j]] Fz[i, j] ⪰ 0`` for every ``i`` (``F0 (N, k, k)``, ``Fz (N, len(idx), k, k)``)."""
        self._psd.append((np.asarray(F0, float), np.asarray(idx), np.asarray(Fz, float)))

    def solve(self, cost: np.ndarray, tol: float = 1e-8) -> tuple[str, np.ndarray | None]:
        """Clarabel's status and its ``z`` (``None`` unless (almost) solved), to relative gap and feasibility ``tol``.

        A Rust panic inside the solver (seen on badly scaled data) is an answer ``"panic"``, not a crash.
        """
        import clarabel

        rows, cols, vals, rhs, cones = [], [], [], [], []
        r0 = 0

        def linear(blocks, cone):
            nonlocal r0
            total = 0
            for g0, idx, gz in blocks:
                N, m = gz.shape
                rows.append(np.repeat(np.arange(N), m) + r0)
                cols.append(np.tile(idx, N))
                vals.append(-gz.ravel())  # Clarabel: A z + s = b, s in the cone; here s = g0 + gz z
                rhs.append(g0)
                r0 += N
                total += N
            if total:
                cones.append(cone(total))

        linear(self._eq, clarabel.ZeroConeT)
        linear(self._nn, clarabel.NonnegativeConeT)
        for F0, idx, Fz in self._psd:
            k = F0.shape[-1]
            s0, sz = svec(F0), svec(Fz)
            for i in range(F0.shape[0]):
                blk = -sz[i].T
                nr, nc = np.nonzero(blk)
                rows.append(nr + r0)
                cols.append(idx[nc])
                vals.append(blk[nr, nc])
                rhs.append(s0[i])
                cones.append(clarabel.PSDTriangleConeT(k))
                r0 += s0.shape[-1]
        A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(r0, self.n))
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = float(tol)
        # Every matrix inequality here is small (order ten) and dense in the decision variables: splitting it into
        # cliques buys nothing, and on the region LMI it made Clarabel stall with NumericalError in one of the two
        # coordinate choices that both solve without it, and take 20-50 % more iterations in the other.
        settings.chordal_decomposition_enable = False
        # One thread: the factorisation of a few hundred columns gains nothing from a second one (20 % slower with
        # two on the region LMI, measured), the test suite and Monte Carlo already run a process per core, and a
        # serial factorisation rounds the same way on every run.
        settings.max_threads = 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sol = clarabel.DefaultSolver(sp.csc_matrix((self.n, self.n)), np.asarray(cost, float), A,
                                             np.concatenate(rhs), cones, settings).solve()
        except BaseException as exc:  # noqa: BLE001  pyo3's PanicException derives from BaseException
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            return "panic", None
        status = str(sol.status)
        return status, (np.array(sol.x, float) if status in ("Solved", "AlmostSolved") else None)
