"""Building a certificate: solve every LMI for a gain set, simulate the reference runs, sign."""

from __future__ import annotations

import math
import platform
from importlib import metadata
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.analysis.sni_loop import reduced_loop
from nniquad.certificates.certificate import (NI_FORM, PERFORMANCE_HORIZON_S, ROA_MODEL, TOLERANCES, Certificate,
                                              reference_run_options)
from nniquad.config import (CASCADE_GRID_POINTS_PER_AXIS, CONTROL_RATE_HZ, DT_S, GAMMA_MAX, MASS_RANGE_FRACTION,
                            TILT_LIMIT_DEG, XI0_M)
from nniquad.control.gains import DEFAULT_INNER_LOOP_GAINS, Gains, InnerLoopGains, SNI2Gains
from nniquad.control.law_classes import DEFAULT_LAW_CLASS
from nniquad.control.law_classes import law_class as law_class_of, within_sector_bound
from nniquad.errors import CertificateError
from nniquad.model.vehicle import Vehicle

if TYPE_CHECKING:
    from nniquad.analysis.cascade.certificate import ParameterBox

__all__ = ["build_certificate", "performance_runs", "margins_section", "MARGIN_FIELDS", "sector_pm_ceiling_deg",
           "sector_section"]


def _software() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in ("nniquad", "numpy", "scipy", "casadi", "cvxpy", "clarabel", "sympy", "control"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


def _mat(M: np.ndarray) -> list[list[float]]:
    return np.asarray(M, dtype=float).tolist()


def performance_runs(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, *, tilt_limit_deg: float = TILT_LIMIT_DEG,
                     xi0: Sequence[float] = XI0_M, horizon_s: float = PERFORMANCE_HORIZON_S,
                     motor_lag: bool = True, rate_hz: float | None = None) -> dict[str, Any]:
    """Settings and metrics of the two reference runs (``reduced`` and ``full``).

    Each run is simulated with the options of
    :func:`nniquad.certificates.certificate.reference_run_options` (which says
    what each run is); its ``settings`` are those complete
    :class:`nniquad.sim.SimOptions` (``to_json``), so it can be re-simulated exactly.

    Parameters
    ----------
    vehicle, gains, inner
        What is simulated.
    tilt_limit_deg, xi0, horizon_s, motor_lag, rate_hz
        As in :func:`~nniquad.certificates.certificate.reference_run_options`.
    """
    from nniquad.sim import simulate

    out = {}
    for model in ("reduced", "full"):
        # the one definition verify compares the stated settings against
        opts = reference_run_options(model, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0, horizon_s=horizon_s,
                                     motor_lag=motor_lag, rate_hz=rate_hz)
        met = simulate(vehicle, gains, opts)[0].metrics()
        out[model] = {"settling_s": met.settling_s, "overshoot_pct": met.overshoot_pct,
                      "peak_tilt_deg": met.peak_tilt_deg, "diverged": met.diverged, "settings": opts.to_json()}
    return out


#: The per-break-point numbers of the ``margins`` section (units in the names).
MARGIN_FIELDS = ("gm_db", "gm_lower_db", "pm_deg", "w_gc_rad_s", "w_pc_rad_s", "stable", "meets_requirement")


def sector_pm_ceiling_deg(gamma_max: float, controller: str = "nni") -> float:
    """Largest phase margin of the law on a pure double integrator under the sector bound [deg].

    ``a_h = -k_p ξ + z/m``, ``z' = -Γδ z + Γ ξ`` is a lead compensator
    ``k_p (s + a)/(s + b)`` with ``a/b = 1 - 1/(m k_p δ)``; the sector bound
    ``m k_p δ >= 1/γ_max`` limits ``b/a`` to ``1/(1 - γ_max)``, so the phase lead, and
    with the double integrator's -180° the phase margin, is at most
    ``asin(γ_max/(2 - γ_max))``: 41.8° at γ_max = 0.8.  The cascade's attitude loop,
    motor lag and sampling only take phase away, so PM >= 45° at the horizontal
    break point is out of reach of every admissible gain set of this law.

    The ``sni2`` law is ``k_p (s² + 2ζωs + ω²(1 - γ))/(s² + 2ζωs + ω²)``: between the frequencies
    ``ω sqrt(1 - γ)`` and ``ω`` of its zero and pole pairs the phase of the numerator exceeds 90° and
    that of the denominator stays below it, and as ``ζ → 0`` the lead there tends to 180° for any
    ``γ > 0``: no ceiling below 180° (what it costs in robustness the cascade margins say).
    """
    if controller == "sni2":
        return 180.0
    g = float(gamma_max)
    return math.degrees(math.asin(g / (2.0 - g)))


def margins_section(vehicle: Vehicle, gains: Gains | SNI2Gains, inner: InnerLoopGains, *,
                    tilt_limit_deg: float = TILT_LIMIT_DEG,
                    gamma_max: float = GAMMA_MAX, rate_hz: float | None = None) -> dict[str, Any]:
    """The certificate's ``margins`` section: classical margins of the linearised cascade.

    :func:`nniquad.analysis.margins.cascade_margins` (python-control ``stability_margins``
    on the exact frequency response) at ``config.CONTROL_RATE_HZ``, the NNI controller in
    discrete time, Padé order 2 for the sampling delays; the horizontal break point also
    exactly in discrete time (``horizontal_zoh``).  ``verify`` recomputes all of it.
    """
    from nniquad.analysis.cascade.linearised import linearise_cascade
    from nniquad.analysis.margins import cascade_margins
    from nniquad.config import CONTROL_RATE_HZ, REQUIRED_GM_DB, REQUIRED_PM_DEG

    rate = CONTROL_RATE_HZ if rate_hz is None else float(rate_hz)
    cas = linearise_cascade(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg)
    ms = cascade_margins(cas, rate, controller="discrete", pade_order=2)
    points = {}
    for name, m in ms.items():
        d = m.to_json()
        points[name] = {k: d[k] for k in MARGIN_FIELDS}
    return {
        "rate_hz": rate, "controller": "discrete", "pade_order": 2, "method": "linearised cascade at hover",
        "required": {"gm_db": REQUIRED_GM_DB, "pm_deg": REQUIRED_PM_DEG},
        "break_points": points,
        "meets_requirement": all(p["meets_requirement"] for p in points.values()),
        "horizontal_pm_ceiling_deg": sector_pm_ceiling_deg(gamma_max, gains.controller),
    }


def sector_section(loop: Any, gamma_max: float) -> dict[str, float]:
    """The certificate's ``sector`` section: ``gamma`` (the DC loop gain ``1/(m kp δ)``, or ``k/(m kp ω²)`` for
    ``sni2``), ``gamma_max``, and the bound on the law's own gain: ``delta_min = 1/(γ_max m kp)`` (NNI) or
    ``k_max = γ_max m kp ω²`` (``sni2``)."""
    out = {"gamma": loop.smallest_gamma, "gamma_max": float(gamma_max)}
    if isinstance(loop.gains, SNI2Gains):
        out["k_max"] = loop.sector_k_max(gamma_max)
    else:
        out["delta_min"] = loop.sector_delta_min(gamma_max)
    return out


def build_certificate(vehicle: Vehicle, gains: Gains | SNI2Gains, *, inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS,
                      gamma_max: float = GAMMA_MAX, tilt_limit_deg: float = TILT_LIMIT_DEG,
                      mass_range: tuple[float, float] | None = None, xi0: Sequence[float] = XI0_M,
                      model: str = "reduced", tuning: Mapping[str, Any] | None = None,
                      progress: Callable[[str], None] | None = None, rate_hz: float = CONTROL_RATE_HZ,
                      cascade: bool = True, box: "ParameterBox | None" = None,
                      widest_box: bool = False, refuse_unsettled: bool = False,
                      grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS,
                      law_class: str = DEFAULT_LAW_CLASS) -> Certificate:
    """Solve every LMI for ``gains``, simulate, and assemble a signed certificate.

    Parameters
    ----------
    vehicle
        The vehicle.
    gains
        The gain set (equal axes): the NNI law's :class:`Gains` or the ``sni2`` law's :class:`SNI2Gains`
        (the same sections; its DC loop gain ``k/(m kp ω²)`` is the sector constant, its controller's
        NI lemma is solved in scaled coordinates, :meth:`nniquad.analysis.sni_loop.SNI2Loop.controller_scaling`).
    inner
        Inner-loop gains of the ``full`` run.
    gamma_max
        Largest admissible sector gain, in (0, 1).
    tilt_limit_deg
        Tilt limit [deg].
    mass_range
        True-mass interval of the robust LMI [kg] (default 0.8 m to 1.2 m).
    xi0
        Initial position of the reference runs [m].
    model
        The model the gains were tuned on (recorded).
    tuning
        How the gains were found (recorded).
    progress
        Called with a short message before each long step.
    rate_hz
        Control rate [Hz] (default :data:`nniquad.config.CONTROL_RATE_HZ`): the
        rate of the ``cascade`` section, of the ``margins`` section and of the
        ``full`` reference run (position sampled, NNI controller in discrete time).
    cascade
        Certify the sampled-data cascade over a parameter box (schema 2, the
        default; :func:`nniquad.analysis.cascade.certificate.cascade_section`).
        ``False`` writes a schema-1 certificate: the continuous reduced loop
        only, the ``full`` reference run continuous, margins at the default rate.
    box
        The parameter box of the cascade section
        (:class:`nniquad.analysis.cascade.certificate.ParameterBox`); ``None``: the
        Monte Carlo default box if it certifies, else its scale halved until it does.
    widest_box
        Search the widest scale of the Monte Carlo default box that certifies
        (bisection, about a minute on 2 cores) and certify that box (with
        ``box=None``); the section's ``box_search`` record states the search.
    grid_points_per_axis
        Points per parameter of the cascade section's numpy grid check (default
        :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS`: 4, so 4096 points).
    refuse_unsettled
        Refuse (before the cascade section) when a reference run is not shown
        to settle (:func:`nniquad.jobs.certify.unsettled_reference_run`;
        what ``certify`` does).
    law_class
        The class of the design (:mod:`nniquad.control.law_classes`): ``"paper"``
        (default) refuses gains outside the sector bound for ``gamma_max``;
        ``"cascade"`` drops the sector bound (the reduced loop must still be stable,
        ``m kp δ > 1``) and needs the cascade section, which is then the proof.
        The certificate states the class and the theorem (``law_class``).

    Raises
    ------
    CertificateError
        The gains violate the sector bound for ``gamma_max`` (class ``paper``), an LMI is
        infeasible (nothing is certified, so nothing is returned), the class is
        unknown or needs a cascade section that is not asked for, or the rate
        is not one the simulator can run (finite, positive, a period of whole RK4 steps).
    """
    from nniquad.analysis.bound import time_optimal_bound
    from nniquad.analysis.lmi import certified_region, closed_loop_decay, ni_lemma_dissipation, reach_of, robust_mass_decay
    from nniquad.sim.options import check_rate_hz

    say = progress or (lambda msg: None)
    rate_hz = check_rate_hz(rate_hz, DT_S, option="rate", error=CertificateError)
    if not isinstance(gains, (Gains, SNI2Gains)):
        raise CertificateError(f"certificates cover the laws of the NI structure (nni, sni2), not a "
                               f"{type(gains).__name__}")
    if isinstance(gains, Gains) and gains.kpy is not None and gains.kpy != gains.kp:
        raise CertificateError("certificates cover equal axis gains only (kpy must equal kp)")
    if not 0.0 < gamma_max < 1.0:
        raise CertificateError(f"gamma_max must lie in (0, 1), got {gamma_max!r}")
    try:
        cls = law_class_of(law_class)
    except ValueError as exc:
        raise CertificateError(str(exc)) from None
    if cls.needs_cascade and not cascade:
        raise CertificateError(f"the {cls.name} class is certified by the sampled-data cascade section: it cannot "
                               "be written without one (schema 1)")
    loop = reduced_loop(vehicle, gains)
    m = vehicle.m
    gamma = loop.smallest_gamma
    if cls.sector_bound and not within_sector_bound(gamma, gamma_max):
        if isinstance(gains, SNI2Gains):
            what = (f"k = {gains.k:.6g} > gamma_max m kp omega^2 = {loop.sector_k_max(gamma_max):.6g} (DC loop gain "
                    f"k/(m kp omega^2) = {gamma:.6g} > gamma_max {gamma_max:g})")
        else:
            what = (f"delta = {gains.delta:.6g} < 1/(gamma_max m kp) = {loop.sector_delta_min(gamma_max):.6g} "
                    f"(smallest gamma {gamma:.6g} > gamma_max {gamma_max:g})")
        raise CertificateError(f"gains violate the sector bound of the paper class: {what}; --law-class cascade "
                               "drops the bound and certifies with the sampled-data cascade alone")
    if not gamma < 1.0:
        what = "k/(m kp omega^2)" if isinstance(gains, SNI2Gains) else "1/(m kp delta)"
        raise CertificateError(f"DC loop gain {what} = {gamma:.6g} >= 1: the reduced loop is not stable "
                               "(no law class certifies it)")
    lo, hi = mass_range if mass_range is not None else (MASS_RANGE_FRACTION[0] * m, MASS_RANGE_FRACTION[1] * m)
    say("solving the LMIs")
    A, B, C, D = loop.plant_matrices()
    plant = ni_lemma_dissipation(A, B, C, D, name="ni_lemma_dissipation[plant]")
    Ac, Bc, Cc, _ = loop.controller_matrices()
    ctrl = ni_lemma_dissipation(Ac, Bc, Cc, name="ni_lemma_dissipation[controller]",
                                scaling=loop.controller_scaling())
    cl = closed_loop_decay(loop)
    rob = robust_mass_decay(loop, lo, hi, parameter_dependent=True, thrust_model=True)
    region = certified_region(loop, tilt_limit_deg)
    (roa,) = region
    for res in (plant, ctrl, cl, rob, roa):
        if not res.feasible:
            raise CertificateError(f"LMI {res.name} is infeasible for these gains (solver status {res.status})")
    pd = loop.poles_and_damping()
    reach = reach_of(region)
    u0 = float(roa.values["u0"])
    if not cascade and rate_hz != CONTROL_RATE_HZ:
        raise CertificateError(f"a schema-1 certificate (no cascade section) states no rate: it cannot be "
                               f"built at {rate_hz:g} Hz")
    say("computing the classical margins")
    margins = margins_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, gamma_max=gamma_max,
                              rate_hz=rate_hz)
    # the reference runs first (seconds): a design that does not settle is refused before the cascade (a minute)
    say("simulating the reference runs")
    perf = performance_runs(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0,
                            rate_hz=rate_hz if cascade else None)
    if refuse_unsettled:
        from nniquad.jobs.certify import unsettled_reference_run

        unsettled = unsettled_reference_run({"performance": perf})
        if unsettled is not None:
            raise CertificateError(f"refused: {unsettled}; nothing certified")
    section = None
    if cascade:
        from nniquad.analysis.cascade.certificate import cascade_section
        from nniquad.errors import CascadeError, SolverError

        say(f"certifying the sampled-data cascade at {rate_hz:g} Hz over the parameter box")
        try:
            section = cascade_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz, box=box,
                                      xi0_m=xi0,
                                      widest=widest_box, grid_points_per_axis=grid_points_per_axis)
        except (CascadeError, SolverError) as exc:
            raise CertificateError(f"the sampled-data cascade is not certified at {rate_hz:g} Hz: {exc}") from None
    bound = time_optimal_bound(vehicle, xi0=xi0, tilt_limit_deg=tilt_limit_deg)
    ratios = {k: (None if v["settling_s"] is None else v["settling_s"] / bound.enter_band_s) for k, v in perf.items()}
    cert = Certificate(
        model=model,
        vehicle=vehicle,
        gains=gains if isinstance(gains, SNI2Gains) else Gains(kp=gains.kp, Gamma=gains.Gamma, delta=gains.delta),
        inner_loop=inner,
        tilt_limit_deg=float(tilt_limit_deg),
        xi0_m=(float(xi0[0]), float(xi0[1])),
        sector=sector_section(loop, gamma_max),
        stability_margin={
            "routh_margin": loop.routh_margin,
            "max_real_part_1_s": float(pd.max_real_part),
            "decay_rate_1_s": float(pd.decay_rate),
            "min_damping": float(pd.min_damping),
            "poles_1_s": [[float(p.real), float(p.imag)] for p in pd.poles],
        },
        lmi={
            "plant_ni": {"P": _mat(plant.matrices["P"]), "form": NI_FORM},
            "controller_ni": {"P": _mat(ctrl.matrices["P"]), "form": NI_FORM},
            "closed_loop": {"P": _mat(cl.matrices["P"]), "decay_rate_1_s": float(cl.values["decay_rate"])},
            "robust_mass": {"m_lo_kg": float(lo), "m_hi_kg": float(hi), "m_nominal_kg": m,
                            "P0": _mat(rob.matrices["P0"]), "P1": _mat(rob.matrices["P1"]),
                            "decay_rate_1_s": float(rob.values["decay_rate"])},
            "region_of_attraction": {"P": _mat(roa.matrices["P"]), "G": _mat(roa.matrices["G"]),
                                     "T": _mat(roa.matrices["T"]), "u0_m_s2": u0,
                                     "max_displacement_m": reach},
        },
        region_of_attraction={"max_displacement_m": reach, "u0_m_s2": u0, "tilt_limit_deg": float(tilt_limit_deg),
                              "model": ROA_MODEL},
        start_certified=bool(math.hypot(*xi0) <= reach),
        performance=perf,
        bound={"enter_band_s": bound.enter_band_s, "rest_to_rest_s": bound.rest_to_rest_s,
               "a_max_m_s2": bound.a_max_m_s2},
        ratio_to_bound=ratios,
        tolerances=dict(TOLERANCES),
        tuning=dict(tuning) if tuning is not None else None,
        software=_software(),
        margins=margins,
        cascade=section,
        law_class={"name": cls.name, "theorem": cls.theorem},
    )
    return cert.signed()
