"""Building a certificate: solve every LMI for a gain set, simulate the reference runs, sign."""

from __future__ import annotations

import platform
from importlib import metadata
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.analysis.bound import time_optimal_bound
from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.cascade.box_certificate import cascade_section
from nniquad.analysis.linearised_cascade import linearise_cascade
from nniquad.analysis.lmi import certified_region, closed_loop_decay, ni_lemma_dissipation, reach_of, robust_mass_decay
from nniquad.analysis.margins import cascade_margins
from nniquad.analysis.reduced_loop import ReducedLoop, reduced_loop
from nniquad.analysis.tracking_section import tracking_section
from nniquad.certificates.integral import integral_action_block, reduced_loop_sections, states_reduced_loop
from nniquad.certificates.start import start_section
from nniquad.certificates.certificate import (
    NI_FORM,
    PERFORMANCE_HORIZON_S,
    ROA_MODEL,
    TOLERANCES,
    Certificate,
    reference_run_options,
)
from nniquad.certificates.reference_run import ReferenceRun, run_metrics
from nniquad.config import (
    CASCADE_GRID_POINTS_PER_AXIS,
    CONTROL_RATE_HZ,
    DT_S,
    GAMMA_MAX,
    MASS_RANGE_FRACTION,
    REQUIRED_GM_DB,
    REQUIRED_PM_DEG,
    TILT_LIMIT_DEG,
    XI0_M,
)
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import CascadeError, CertificateError, SolverError
from nniquad.laws.base import GainBlock
from nniquad.laws.classes import DEFAULT_LAW_CLASS, law_class as law_class_of, within_sector_bound
from nniquad.laws.registry import law_named, ni_law_names
from nniquad.model.vehicle import Vehicle
from nniquad.sim.options import check_delay_samples, check_rate_hz
from nniquad.tuning.objective import required_hold_s, settling_shown

__all__ = ["build_certificate", "BUILD_STEPS", "unsettled_reference_run", "performance_runs", "margins_section", "MARGIN_FIELDS", "sector_pm_ceiling_deg",
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


def performance_runs(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *, tilt_limit_deg: float = TILT_LIMIT_DEG,
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

    out = {}
    for model in ("reduced", "full"):
        # the one definition verify compares the stated settings against; the run is the object
        # Certificate.run_settings reads back from the recorded settings
        run = ReferenceRun(vehicle, gains, reference_run_options(model, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0,
                                                                 horizon_s=horizon_s, motor_lag=motor_lag,
                                                                 rate_hz=rate_hz))
        out[model] = {**run_metrics(run.simulate()[0].metrics()), "settings": run.options.to_json()}
    return out


#: The progress messages :func:`build_certificate` sends with a cascade section (one per step: the LMIs, the
#: margins, the reference runs, the cascade; one fewer without a cascade section).
BUILD_STEPS = 4

#: The per-break-point numbers of the ``margins`` section (units in the names).
MARGIN_FIELDS = ("gm_db", "gm_lower_db", "pm_deg", "w_gc_rad_s", "w_pc_rad_s", "stable", "meets_requirement")


def sector_pm_ceiling_deg(gamma_max: float, controller: str = "nni") -> float:
    """Largest phase margin of the law on a pure double integrator under the sector bound [deg]
    (:meth:`nniquad.laws.base.NILaw.pm_ceiling_deg`: ``asin(γ_max/(2 - γ_max))``, 41.8° at γ_max = 0.8, for the
    NNI law; no ceiling below 180° for ``sni2``).  The cascade's attitude loop, motor lag and sampling only take
    phase away.

    Parameters
    ----------
    gamma_max
        The sector bound's ceiling.
    controller
        The law's name.
    """
    law = law_named(controller)
    # a law outside the NI structure (integral action) has no sector bound: no ceiling below 180
    return law.pm_ceiling_deg(gamma_max) if states_reduced_loop(law) else 180.0


def margins_section(vehicle: Vehicle, gains: GainBlock, inner: InnerLoopGains, *,
                    tilt_limit_deg: float = TILT_LIMIT_DEG,
                    gamma_max: float = GAMMA_MAX, rate_hz: float | None = None) -> dict[str, Any]:
    """The certificate's ``margins`` section: classical margins of the linearised cascade.

    :func:`nniquad.analysis.margins.cascade_margins` (python-control ``stability_margins``
    on the exact frequency response) at ``config.CONTROL_RATE_HZ``, the NNI controller in
    discrete time, Padé order 2 for the sampling delays; the horizontal break point also
    exactly in discrete time (``horizontal_zoh``).  ``verify`` recomputes all of it.
    """

    rate = CONTROL_RATE_HZ if rate_hz is None else float(rate_hz)
    cas = linearise_cascade(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg)
    ms = cascade_margins(cas, rate, variant="discrete", pade_order=2)
    points = {}
    for name, m in ms.items():
        d = m.to_json()
        points[name] = {k: d[k] for k in MARGIN_FIELDS}
    return {
        "rate_hz": rate, "controller": "discrete", "pade_order": 2, "method": "linearised cascade at hover",
        "required": {"gm_db": REQUIRED_GM_DB, "pm_deg": REQUIRED_PM_DEG},
        "break_points": points,
        "meets_requirement": all(p["meets_requirement"] for p in points.values()),
        "horizontal_pm_ceiling_deg": sector_pm_ceiling_deg(gamma_max, gains.law.name),
    }


def sector_section(loop: ReducedLoop, gamma_max: float) -> dict[str, float]:
    """The certificate's ``sector`` section: ``gamma`` (the DC loop gain: ``1/(m kp δ)`` for the NNI law,
    ``k/(m kp ω²)`` for ``sni2``), ``gamma_max``, and the bound it puts on the law's own gain
    (:meth:`nniquad.laws.base.NILaw.sector_limit`: ``delta_min = 1/(γ_max m kp)`` or ``k_max = γ_max m kp ω²``).

    Parameters
    ----------
    loop
        The certified reduced loop.
    gamma_max
        The sector bound's ceiling.
    """
    key, limit = loop.sector_limit(gamma_max)
    return {"gamma": loop.smallest_gamma, "gamma_max": float(gamma_max), key: limit}


def build_certificate(vehicle: Vehicle, gains: GainBlock, *, inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS,
                      gamma_max: float = GAMMA_MAX, tilt_limit_deg: float = TILT_LIMIT_DEG,
                      mass_range: tuple[float, float] | None = None, xi0: Sequence[float] = XI0_M,
                      model: str = "reduced", tuning: Mapping[str, Any] | None = None,
                      progress: Callable[[str], None] | None = None, rate_hz: float = CONTROL_RATE_HZ,
                      cascade: bool = True, box: ParameterBox | None = None,
                      widest_box: bool = False, refuse_unsettled: bool = False,
                      grid_points_per_axis: int = CASCADE_GRID_POINTS_PER_AXIS,
                      law_class: str = DEFAULT_LAW_CLASS, tracking: bool = True,
                      tracking_corners: bool = False, delay_samples: int = 0) -> Certificate:
    """Solve every LMI for ``gains``, simulate, and assemble a signed certificate.

    Parameters
    ----------
    vehicle
        The vehicle.
    gains
        The gain set (equal axes): the NNI law's :class:`Gains` or the ``sni2`` law's :class:`SNI2Gains`
        (the same sections; its DC loop gain ``k/(m kp ω²)`` is the sector constant, its controller's
        NI lemma is solved in scaled coordinates, :meth:`nniquad.laws.base.NILaw.controller_scaling`).
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
        default; :func:`nniquad.analysis.cascade.box_certificate.cascade_section`).
        ``False`` writes a schema-1 certificate: the continuous reduced loop
        only, the ``full`` reference run continuous, margins at the default rate.
    box
        The parameter box of the cascade section
        (:class:`nniquad.analysis.cascade.box_certificate.ParameterBox`); ``None``: the
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
        to settle (:func:`unsettled_reference_run`;
        what ``certify`` does).
    law_class
        The class of the design (:mod:`nniquad.laws.classes`): ``"paper"``
        (default) refuses gains outside the sector bound for ``gamma_max``;
        ``"cascade"`` drops the sector bound (the reduced loop must still be stable,
        ``m kp δ > 1``) and needs the cascade section, which is then the proof.
        The certificate states the class and the theorem (``law_class``).
    tracking
        With a cascade section, also state the tracking-error bound for the default class
        (:func:`nniquad.analysis.tracking_section.tracking_section`, about a second).
    tracking_corners
        The tracking bound covers the corners of the cascade section's box too (about 20 s more); else the
        nominal vehicle.
    delay_samples
        Measurement delay [control periods] the cascade section certifies (a delay line between the position
        and the law; stated as ``delay_samples``, top level and in the section).  Needs the cascade section.
        The reference runs are flown without it.

    Raises
    ------
    CertificateError
        The gains violate the sector bound for ``gamma_max`` (class ``paper``), an LMI is
        infeasible (nothing is certified, so nothing is returned), the class is
        unknown or needs a cascade section that is not asked for, or the rate
        is not one the simulator can run (finite, positive, a period of whole RK4 steps).
    """

    say = progress or (lambda msg: None)
    rate_hz = check_rate_hz(rate_hz, DT_S, option="rate", error=CertificateError)
    delay_samples = check_delay_samples(delay_samples, sampled=cascade, error=CertificateError)
    if not (isinstance(gains, GainBlock) and (gains.law.ni_structure or gains.law.integral)):
        raise CertificateError(f"certificates cover the laws of the NI structure ({', '.join(ni_law_names())}) and "
                               f"their integral variants, not a {type(gains).__name__}")
    if len(set(gains.axes())) != 1:
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
    m = vehicle.m
    lo, hi = mass_range if mass_range is not None else (MASS_RANGE_FRACTION[0] * m, MASS_RANGE_FRACTION[1] * m)
    if not cascade and rate_hz != CONTROL_RATE_HZ:
        raise CertificateError(f"a schema-1 certificate (no cascade section) states no rate: it cannot be "
                               f"built at {rate_hz:g} Hz")
    if states_reduced_loop(gains.law):
        sections = _reduced_loop_sections(vehicle, gains, cls, gamma_max, tilt_limit_deg, (lo, hi), say)
    elif cls.sector_bound or not cascade:
        raise CertificateError(f"the {gains.law.name} law (integral action) is certified by the sampled-data cascade "
                               "section alone: --law-class cascade, with the cascade section")
    else:
        sections = reduced_loop_sections(gains.law)  # no reduced-loop theorem: why, in each section
    say("computing the classical margins")
    margins = margins_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, gamma_max=gamma_max,
                              rate_hz=rate_hz)
    # the reference runs first (seconds): a design that does not settle is refused before the cascade (a minute)
    say("simulating the reference runs")
    perf = performance_runs(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0,
                            rate_hz=rate_hz if cascade else None)
    if refuse_unsettled:
        unsettled = unsettled_reference_run({"performance": perf})
        if unsettled is not None:
            raise CertificateError(f"refused: {unsettled}; nothing certified")
    section = None
    if cascade:

        say(f"certifying the sampled-data cascade at {rate_hz:g} Hz over the parameter box")
        try:
            section = cascade_section(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, rate_hz=rate_hz, box=box,
                                      xi0_m=xi0,
                                      widest=widest_box, grid_points_per_axis=grid_points_per_axis,
                                      delay_samples=delay_samples)
        except (CascadeError, SolverError) as exc:
            raise CertificateError(f"the sampled-data cascade is not certified at {rate_hz:g} Hz: {exc}") from None
    track = None
    if section is not None and tracking:  # a second: part of the cascade step (BUILD_STEPS)
        box_used = ParameterBox.from_json(section["box"]) if tracking_corners else None
        try:
            track = tracking_section(vehicle, gains, inner, rate_hz=rate_hz, tilt_limit_deg=tilt_limit_deg,
                                     box=box_used)
        except CascadeError as exc:
            raise CertificateError(f"the tracking-error bound is not certified: {exc}") from None
    bound = time_optimal_bound(vehicle, xi0=xi0, tilt_limit_deg=tilt_limit_deg)
    # the start per method; start_certified never claims more than the weakest of them
    start = start_section(xi0, sections["region_of_attraction"], section)
    ratios = {k: (None if v["settling_s"] is None else v["settling_s"] / bound.enter_band_s) for k, v in perf.items()}
    law_class_block = {"name": cls.name, "theorem": cls.theorem}
    if not states_reduced_loop(gains.law):
        law_class_block["integral_action"] = integral_action_block(gains.law)
    cert = Certificate(
        model=model,
        vehicle=vehicle,
        gains=type(gains).from_values(gains.values()),  # canonical: a second-axis gain equal to the first is dropped
        inner_loop=inner,
        tilt_limit_deg=float(tilt_limit_deg),
        xi0_m=(float(xi0[0]), float(xi0[1])),
        **sections,
        start_certified=start["every_method"],
        performance=perf,
        bound={"enter_band_s": bound.enter_band_s, "rest_to_rest_s": bound.rest_to_rest_s,
               "a_max_m_s2": bound.a_max_m_s2},
        ratio_to_bound=ratios,
        tolerances=dict(TOLERANCES),
        tuning=dict(tuning) if tuning is not None else None,
        software=_software(),
        margins=margins,
        cascade=section,
        law_class=law_class_block,
        start=start,
        tracking=track,
        delay_samples=delay_samples if section is not None else None,
    )
    return cert.signed()


def _reduced_loop_sections(vehicle: Vehicle, gains: GainBlock, cls: Any, gamma_max: float, tilt_limit_deg: float,
                           mass_range: tuple[float, float], say: Callable[[str], None]) -> dict[str, Any]:
    """The paper's reduced-loop sections of a law of the NI structure (``sector``, ``stability_margin``, ``lmi``,
    ``region_of_attraction``), after the sector bound of the class; raises :class:`CertificateError`."""
    m = vehicle.m
    loop = reduced_loop(vehicle, gains)
    gamma = loop.smallest_gamma
    if cls.sector_bound and not within_sector_bound(gamma, gamma_max):
        what = gains.law.sector_violation(gains, m, gamma_max)
        raise CertificateError(f"gains violate the sector bound of the paper class: {what}; --law-class cascade "
                               "drops the bound and certifies with the sampled-data cascade alone")
    if not gamma < 1.0:
        what = gains.law.gamma_formula
        raise CertificateError(f"DC loop gain {what} = {gamma:.6g} >= 1: the reduced loop is not stable "
                               "(no law class certifies it)")
    lo, hi = mass_range
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
    return {
        "sector": sector_section(loop, gamma_max),
        "stability_margin": {
            "routh_margin": loop.routh_margin,
            "max_real_part_1_s": float(pd.max_real_part),
            "decay_rate_1_s": float(pd.decay_rate),
            "min_damping": float(pd.min_damping),
            "poles_1_s": [[float(p.real), float(p.imag)] for p in pd.poles],
        },
        "lmi": {
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
        "region_of_attraction": {"max_displacement_m": reach, "u0_m_s2": u0, "tilt_limit_deg": float(tilt_limit_deg),
                                 "model": ROA_MODEL}}


def unsettled_reference_run(cert: Certificate | Mapping[str, Any]) -> str | None:
    """Why a certificate's reference runs do not show settling, or ``None`` when both do.

    The rule is the tuner's (:func:`nniquad.tuning.tune.settling_shown`): a last exit
    at ``s`` counts only if the run is then seen inside the band for
    ``max(5 s, 2 s)`` before its horizon ends.  A run that never settles, that
    diverges, or whose last exit comes too late to be shown is refused: the
    certificate would state a performance it has not observed (``docs/notes/certificates.md``).

    Parameters
    ----------
    cert
        A :class:`Certificate` or its JSON content.

    Returns
    -------
    str or None
        A one-line reason naming the reference run, or ``None``.
    """
    perf = cert["performance"] if isinstance(cert, Mapping) else cert.performance  # JSON content or Certificate
    for model, run in perf.items():
        horizon = float(run["settings"]["horizon_s"])
        s = run["settling_s"]
        if run.get("diverged"):
            return f"the {model} reference run diverged (the vehicle was lost: it blew up or lost its altitude)"
        if s is None:
            return f"the {model} reference run did not settle within its {horizon:g} s horizon"
        if not settling_shown(s, horizon):
            return (f"the {model} reference run was last in the band from {s:.3g} s, but is not shown to stay "
                    f"there for {required_hold_s(s):.3g} s within its {horizon:g} s horizon")
    return None
