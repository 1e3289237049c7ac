"""Definition-level NI / SNI checks in the frequency domain, independent of the LMIs.

The paper's Definitions ``def:NI`` and ``def:SNI`` (after Lanzon & Petersen 2008)
are checked literally:

* poles: none in ``Re s > 0`` and none at the origin (NI); none in ``Re s >= 0`` (SNI);
* ``j (G(jw) - G(jw)^*) >= 0`` (NI) or ``> 0`` (SNI) on a logarithmic frequency grid
  (:meth:`nniquad.analysis.loops.LinearSystem.frequency_response`, python-control's
  evaluation written with numpy), with grid points that fall on an imaginary-axis
  pole removed;
* at each imaginary-axis pole ``j w0``: the pole is simple and the residue matrix
  ``K0 = lim_{s -> j w0} (s - j w0) s G(s)`` is Hermitian positive semidefinite.
  The residue is computed from the eigen-decomposition of A
  (``G(s) = sum_i C v_i w_i^* B / (s - lambda_i)``); the tests compare it with a
  sympy limit.

:func:`ni_interconnection_check` applies the Lanzon-Petersen stability result
(IEEE TAC 53(4), 2008, recalled, not quoted): the positive-feedback loop of an NI
``G`` and an SNI ``C`` with ``G(inf) C(inf) = 0`` and ``G(inf) >= 0`` is internally
stable iff ``lambda_max(G(0) C(0)) < 1``.  For this loop ``G(0) C(0) = 1/(m kp delta)``,
the same quantity as the Routh condition and the paper's smallest sector γ.

A system is a :class:`nniquad.analysis.loops.LinearSystem` or a python-control
``StateSpace`` / ``TransferFunction``; python-control is imported only for a
transfer function (its realisation), so ``nniquad lmi`` runs without it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nniquad.analysis.loops import as_linear_system, feedback_matrix

__all__ = ["FrequencyResult", "ni_check", "residues_on_imaginary_axis", "InterconnectionResult", "ni_interconnection_check"]


@dataclass
class FrequencyResult:
    """Outcome of a definition-level NI / SNI check.

    Attributes
    ----------
    is_ni, is_sni
        Verdicts of the paper's Definitions ``def:NI`` and ``def:SNI``.
    rhp_poles, origin_poles, imaginary_poles
        Poles in ``Re s > 0``, at 0, and on the imaginary axis off the origin (1/s).
    residues
        For each imaginary-axis pole ``j w0`` (``w0 > 0``): ``(w0, K0)`` with K0 the residue matrix.
    residue_min_eig
        Smallest eigenvalue over all K0 (``inf`` when there is none).
    simple_imaginary_poles
        Whether every imaginary-axis pole is simple.
    grid_min_eig
        Smallest eigenvalue of ``j(G - G^*)`` on the grid.
    grid_min_eig_relative
        The same divided by ``max |G(jw)|`` on the grid.
    omega
        The grid (rad/s).
    notes
        Reasons for a negative verdict.
    """

    is_ni: bool
    is_sni: bool
    rhp_poles: np.ndarray
    origin_poles: np.ndarray
    imaginary_poles: np.ndarray
    residues: list[tuple[float, np.ndarray]]
    residue_min_eig: float
    simple_imaginary_poles: bool
    grid_min_eig: float
    grid_min_eig_relative: float
    omega: np.ndarray = field(repr=False)
    notes: list[str] = field(default_factory=list)


def _pole_sets(poles: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    scale = np.maximum(1.0, np.abs(poles))
    on_axis = np.abs(poles.real) <= tol * scale
    origin = on_axis & (np.abs(poles) <= tol)
    rhp = (poles.real > tol * scale)
    imag = on_axis & ~origin & (poles.imag > 0)
    return poles[rhp], poles[origin], poles[imag]


def residues_on_imaginary_axis(sys, tol: float = 1e-9) -> tuple[list[tuple[float, np.ndarray]], bool]:
    """Residue matrices ``K0 = lim (s - j w0) s G(s)`` at the poles ``j w0``, ``w0 > 0``.

    Parameters
    ----------
    sys : control.StateSpace
        A minimal realisation.
    tol
        Relative tolerance that decides whether an eigenvalue lies on the imaginary axis.

    Returns
    -------
    residues : list of (w0, K0)
    simple : bool
        False if an imaginary-axis eigenvalue is defective (a pole of order > 1).
    """
    A, B, C = np.asarray(sys.A), np.asarray(sys.B), np.asarray(sys.C)
    lam, V = np.linalg.eig(A)
    W = np.linalg.inv(V)
    _, _, imag = _pole_sets(lam, tol)
    out, simple = [], True
    done: list[complex] = []
    for p in imag:
        if any(abs(p - q) <= tol * max(1.0, abs(p)) for q in done):
            continue
        done.append(p)
        idx = [i for i, l in enumerate(lam) if abs(l - p) <= 1e-6 * max(1.0, abs(p))]
        n = A.shape[0]
        # A pole of order > 1 shows up as a defective eigenvalue: geometric < algebraic multiplicity
        geometric = n - np.linalg.matrix_rank(A - p * np.eye(n), tol=1e-8 * max(1.0, np.linalg.norm(A)))
        if geometric < len(idx):
            simple = False
            continue
        res = sum(np.outer(C @ V[:, i], W[i, :] @ B) for i in idx)  # residue of G at p
        out.append((float(p.imag), p * res))  # K0 = p * Res_p G   (the factor s evaluated at p)
    return out, simple


def ni_check(sys, omega: np.ndarray | None = None, tol: float = 1e-9, n_points: int = 2000) -> FrequencyResult:
    """Definition-level NI and SNI check of a square LTI system.

    Parameters
    ----------
    sys : LinearSystem, control.StateSpace or control.TransferFunction
        The system; a transfer function is realised in state space for the residues.
    omega
        Frequency grid (rad/s); default ``n_points`` log-spaced points spanning three
        decades beyond the smallest and largest pole magnitude.
    tol
        Relative tolerance for the eigenvalue tests.

    Returns
    -------
    FrequencyResult
    """
    ss = as_linear_system(sys)
    poles = np.asarray(ss.poles(), dtype=complex)
    rhp, origin, imag = _pole_sets(poles, tol)
    if omega is None:
        mags = np.abs(poles[np.abs(poles) > tol]) if poles.size else np.array([1.0])
        mags = mags if mags.size else np.array([1.0])
        omega = np.logspace(np.log10(mags.min()) - 3, np.log10(mags.max()) + 3, n_points)
    omega = np.asarray(omega, dtype=float)
    keep = np.ones(omega.shape, dtype=bool)
    for p in imag:
        keep &= np.abs(omega - p.imag) > 1e-6 * p.imag
    omega = omega[keep]
    G = ss.frequency_response(omega)  # (outputs, inputs, frequencies)
    if G.shape[0] != G.shape[1]:
        raise ValueError("NI is defined for square systems only")
    H = 1j * (G - np.conj(np.transpose(G, (1, 0, 2))))
    eigs = np.array([np.linalg.eigvalsh(H[:, :, k]) [0] for k in range(H.shape[2])])
    gmax = float(np.max(np.abs(G))) if G.size else 1.0
    grid_min = float(eigs.min())
    residues, simple = residues_on_imaginary_axis(ss, tol)
    res_min = min((float(np.linalg.eigvalsh(0.5 * (K + K.conj().T))[0]) for _, K in residues), default=float("inf"))
    herm = all(np.linalg.norm(K - K.conj().T) <= 1e-8 * max(1.0, np.linalg.norm(K)) for _, K in residues)
    notes = []
    if rhp.size:
        notes.append(f"{rhp.size} pole(s) in Re s > 0")
    if origin.size:
        notes.append(f"{origin.size} pole(s) at the origin")
    if grid_min < -tol * gmax:
        notes.append(f"j(G - G*) has a negative eigenvalue {grid_min:.3g} on the grid")
    if not simple:
        notes.append("an imaginary-axis pole is not simple")
    if residues and (res_min < -tol * max(1.0, max(np.linalg.norm(K) for _, K in residues)) or not herm):
        notes.append(f"residue matrix not Hermitian PSD (min eig {res_min:.3g})")
    is_ni = not notes
    sni_notes = []
    if imag.size or origin.size or rhp.size:
        sni_notes.append("pole(s) in Re s >= 0")
    if not np.all(eigs > tol * 1e-3 * gmax):
        sni_notes.append("j(G - G*) is not positive definite at every grid frequency")
    is_sni = not sni_notes
    notes += [f"not SNI: {n}" for n in sni_notes]
    return FrequencyResult(
        is_ni=is_ni,
        is_sni=is_sni,
        rhp_poles=rhp,
        origin_poles=origin,
        imaginary_poles=imag,
        residues=residues,
        residue_min_eig=res_min,
        simple_imaginary_poles=simple,
        grid_min_eig=grid_min,
        grid_min_eig_relative=grid_min / gmax if gmax > 0 else grid_min,
        omega=omega,
        notes=notes,
    )


@dataclass
class InterconnectionResult:
    """Lanzon-Petersen test of the positive-feedback loop of an NI plant and an SNI controller.

    Attributes
    ----------
    plant, controller
        Definition-level checks of each side.
    dc_loop_gain
        ``lambda_max(G(0) C(0))``.
    predicted_stable
        ``plant.is_ni and controller.is_sni and dc_loop_gain < 1`` (and the
        high-frequency conditions, which hold for strictly proper systems).
    poles
        Closed-loop poles of the positive-feedback interconnection
        (:func:`nniquad.analysis.loops.feedback_matrix`, python-control's
        ``feedback(G, C, sign=+1)``; the tests compare them).
    poles_stable
        Whether all of them lie in ``Re s < 0``.
    """

    plant: FrequencyResult
    controller: FrequencyResult
    dc_loop_gain: float
    predicted_stable: bool
    poles: np.ndarray
    poles_stable: bool


def ni_interconnection_check(G, C) -> InterconnectionResult:
    """NI stability test of the positive-feedback loop ``G``-``C`` and its closed-loop poles."""
    G, C = as_linear_system(G), as_linear_system(C)
    g, c = ni_check(G), ni_check(C)
    G0 = np.atleast_2d(G.dc_gain())
    C0 = np.atleast_2d(C.dc_gain())
    dc = float(np.max(np.linalg.eigvals(G0 @ C0).real))
    Ginf = np.atleast_2d(G.D)
    Cinf = np.atleast_2d(C.D)
    hf_ok = np.allclose(Ginf @ Cinf, 0.0) and np.all(np.linalg.eigvalsh(0.5 * (Ginf + Ginf.T)) >= 0)
    poles = np.linalg.eigvals(feedback_matrix(G, C, sign=+1)).astype(complex)
    return InterconnectionResult(
        plant=g,
        controller=c,
        dc_loop_gain=dc,
        predicted_stable=bool(g.is_ni and c.is_sni and hf_ok and dc < 1.0),
        poles=poles,
        poles_stable=bool(np.all(poles.real < 0)),
    )
