"""The jobs ``certify`` and ``verify``: issue a certified gain set, and check one independently."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping

from nniquad.certificates.build import BUILD_STEPS, build_certificate, unsettled_reference_run
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.verify import Verification, verify_certificate
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import CertificateCheckError, CertificateError, NniquadError
from nniquad.laws.base import GainBlock
from nniquad.laws.registry import law_names
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle
from nniquad.tuning.tune import TuneOptions, TuneResult, tune

__all__ = ["certify", "verify", "certify_steps"]


def certify_steps(tuned: bool) -> int:
    """The status lines :func:`certify` sends after any tuning (the certificate's steps and its verification), plus
    one for the tuning when ``tuned``: the ``total`` of :meth:`nniquad.progress.Progress.steps`.

    Parameters
    ----------
    tuned
        Whether the gains are tuned first (one step, whose own messages do not advance the count).
    """
    return BUILD_STEPS + 1 + int(tuned)


def certify(vehicle: Vehicle | None = None, gains: Any = None, *, inner: InnerLoopGains | None = None,
            options: Any = None, progress: Callable[[str], None] | None = None,
            rate_hz: float | None = None, box: Any = None, widest_box: bool = False,
            tuning_record: Mapping[str, Any] | None = None, delay_samples: int = 0) -> Certificate:
    """Tune (unless gains are given), solve every LMI, simulate the reference runs and sign.

    The certificate is verified independently (:func:`verify`) before it is
    returned, so a certificate this function returns always verifies.

    Parameters
    ----------
    vehicle
        The vehicle; default the paper's.
    gains
        Gains to certify: of a law of the NI structure (:class:`nniquad.laws.nni.Gains`, the ``sni2``
        law's :class:`~nniquad.laws.sni2.SNI2Gains`, ...), or of a law certified through its NNI image
        (:class:`~nniquad.laws.pd_filtered.PDFilteredGains`,
        :meth:`nniquad.laws.base.ControlLaw.ni_image`); a
        :class:`nniquad.tuning.tune.TuneResult` (its gains and inner loops, and
        the record of how they were found); or ``None``, which tunes them first
        with ``options``.
    inner
        Inner-loop gains of the ``full`` reference run (with given ``gains``;
        default :data:`nniquad.control.inner_gains.DEFAULT_INNER_LOOP_GAINS`).  When the
        gains are tuned, the inner loops are tuned with them.
    options
        A :class:`nniquad.tuning.tune.TuneOptions`: the model, ``gamma_max``, the
        law class (``law_class``: ``paper`` or ``cascade``), the
        tilt limit and the mass interval of the certificate, and how to tune
        (default: those of a given :class:`~nniquad.tuning.tune.TuneResult`, else
        ``TuneOptions()``).
    progress
        Called with one-line status messages.
    box
        Parameter box of the sampled-data cascade section
        (:class:`nniquad.analysis.cascade.box_certificate.ParameterBox`); ``None``: the Monte
        Carlo default box if it certifies, else its scale halved until it does.
    widest_box
        Also search the widest scale of the Monte Carlo default box that certifies
        (about a minute more) and certify that box.
    rate_hz
        Control rate of the certificate [Hz] (default ``options.rate_hz``, the rate the
        tuner ranked the candidates at; :func:`build_certificate`).
    tuning_record
        With given ``gains``: the record of the tune that found them (the ``tuning``
        section of the certificate or ``tune --json`` file they come from), kept as
        this certificate's ``tuning`` record when it was tuned on ``options.model``
        (a record, never checked but for its model; ``certify --gains-from``).
    delay_samples
        Measurement delay [samples] the cascade section certifies (:func:`build_certificate`; ``nniquad certify``
        defaults to :data:`nniquad.config.ROBUST_DELAY_SAMPLES`).

    Returns
    -------
    Certificate
        Signed (SHA-256 digest of the canonical content); write it with
        :meth:`Certificate.write` or :func:`nniquad.certificates.write_certificate`.

    Raises
    ------
    CertificateError
        The gains violate the sector bound (class ``paper``), an LMI is infeasible, or the
        certificate fails its own verification, or a reference run does not
        settle, diverges or is not seen to stay in the band for the hold time
        (:func:`nniquad.certificates.build.unsettled_reference_run`): nothing is certified.
    """
    vehicle = PAPER_VEHICLE if vehicle is None else vehicle
    if options is None:
        options = gains.options if isinstance(gains, TuneResult) else TuneOptions()
    if not isinstance(options, TuneOptions):
        raise NniquadError("options must be a TuneOptions")
    say = progress or (lambda msg: None)
    tuning: dict[str, Any]
    if not options.law.certifiable:
        raise NniquadError(f"the {options.controller} law is no law of the NI structure and has no NNI image: there "
                           "is nothing to certify")
    if gains is None or isinstance(gains, TuneResult):
        if inner is not None:
            raise NniquadError("the inner loops are tuned with the gains: give gains to certify given inner loops")
        res = tune(vehicle, options, progress=progress) if gains is None else gains
        gains, inner = res.gains, res.inner
        tuning = {"source": "nniquad tune", **res.to_json()}
    else:
        inner = DEFAULT_INNER_LOOP_GAINS if inner is None else inner
        tuning = {"source": "given gains"}
        if isinstance(tuning_record, Mapping) and tuning_record.get("model") == options.model:
            tuning = {**tuning_record, "source": "given gains, with the record of the tune that found them"}
    if not isinstance(gains, GainBlock):
        raise NniquadError(f"gains must be a gain block of a registered law ({', '.join(law_names())}), got "
                           f"{type(gains).__name__}")
    # the class: paper unless stated; a law with integral action has the cascade class alone
    law_class = options.law_class if options.law_class is not None else (gains.law.law_classes[0] or "paper")
    # a law with integral action is certified as itself, by the cascade class (nniquad.certificates.integral)
    image = gains if gains.law.integral else gains.law.ni_image(gains, vehicle.m)
    if image is None:
        raise NniquadError(f"the {gains.law.name} law is no law of the NI structure and has no NNI image: there is "
                           "nothing to certify")
    if image is not gains:  # a filtered PD is the NNI law with these gains: certified as that image
        tuning["certified_as_nni_image_of"] = {gains.law.name: gains.as_dict()}
        gains = image
    cert = build_certificate(vehicle, gains, inner=inner, gamma_max=options.gamma_max,
                             tilt_limit_deg=options.tilt_limit_deg, mass_range=options.mass_range,
                             model=options.model, tuning=tuning, progress=progress,
                             box=box, widest_box=widest_box, refuse_unsettled=True, law_class=law_class,
                             rate_hz=options.rate_hz if rate_hz is None else rate_hz, delay_samples=delay_samples)
    unsettled = unsettled_reference_run(cert)
    if unsettled is not None:
        raise CertificateError(f"refused: {unsettled}; nothing certified")
    say("verifying before writing")
    check = verify_certificate(cert)
    if not check.ok:
        bad = check.first_failure
        raise CertificateCheckError(f"certificate failed its own verification ({bad.name}: {bad.detail}); "
                               "nothing certified")
    return cert


def verify(certificate: Certificate | Mapping[str, Any] | str | Path, *, simulate: bool = True,
           progress: Callable[[str], None] | None = None, fail_fast: bool = False,
           thorough: bool = False) -> Verification:
    """Recompute everything a certificate states, independently, with numpy and the simulator.

    Parameters
    ----------
    certificate
        A :class:`Certificate`, its JSON content, or the path of a certificate file.
    simulate
        Also re-simulate the reference runs (default); ``False`` checks the
        digest and every matrix condition only.
    progress
        Called with one-line status messages.
    fail_fast
        Stop at the first failed check.
    thorough
        Also prove the cascade's Lyapunov inequality over every cell of its parameter box (several seconds to a
        minute; without it a stated ``box_proof`` is checked for form only).

    Returns
    -------
    Verification
        One check per statement; ``ok`` only if every check passed; ``notes``
        say what the certificate does not cover and which fields are records.

    Raises
    ------
    CertificateError
        The document is not a certificate (unreadable, wrong schema or version,
        digest mismatch, malformed field).
    """
    return verify_certificate(certificate, simulate=simulate, progress=progress, fail_fast=fail_fast,
                              thorough=thorough)
