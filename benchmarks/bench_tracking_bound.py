"""The certified tracking-error bound (issue 45, item 6): stated, recomputed, and flown against.

For each committed certificate (the paper's vehicle: two NNI designs and one ``sni2``; the 3DR Iris of
``tests/data``), at the nominal vehicle and the default class (:data:`nniquad.config.TRACKING_ACCEL_LIMIT_M_S2`,
:data:`nniquad.config.TRACKING_JERK_LIMIT_M_S3`):

* the bound without and with feedforward [m] (:func:`nniquad.analysis.tracking_bound.tracking_bound`), and
  whether the section :func:`nniquad.analysis.tracking_section.tracking_section` writes is reproduced by the check
  ``verify`` runs (:func:`nniquad.analysis.tracking_section.check_tracking_section`);
* figure-eights of the class flown on the ``full`` model (motor lag, the law in discrete time at the certified
  rate, started on the reference): ``figure8:1.5,0.75,8`` without feedforward (its command stays in the linear
  zone) and ``figure8:2,1,8`` with it; the largest error against the bound for the reference's own peaks
  (target: at most 1, for the references :func:`nniquad.analysis.tracking_bound.classify_reference` puts inside
  the class and the zone), and the tightness, bound / error, stated.  A reference outside the zone is stated, not
  judged.

``--quick``: the first certificate only.  Usage: ``python benchmarks/run.py --only tracking_bound [--quick]``.
"""

from __future__ import annotations

from bench_follow import CERTIFICATES  # the same certificates as the follow benchmark (benchmarks/ is on the path)

__all__ = ["run"]

#: (amplitudes north and east [m], period [s], feedforward) of the flown references.
FLIGHTS = (((1.5, 0.75), 8.0, False), ((2.0, 1.0), 8.0, True))


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    import numpy as np

    from nniquad.analysis.tracking_bound import classify_reference, tracking_bound
    from nniquad.analysis.tracking_section import check_tracking_section, section_of_bound
    from nniquad.certificates.certificate import read_certificate
    from nniquad.certificates.export import certified_rate_hz
    from nniquad.control.references import FigureEight
    from nniquad.sim import SimOptions, simulate

    rows = []
    for name, path in list(CERTIFICATES.items())[: 1 if quick else None]:
        cert = read_certificate(path)
        rate = certified_rate_hz(cert)
        tb = tracking_bound(cert.vehicle, cert.gains, cert.inner_loop, rate_hz=rate,
                            tilt_limit_deg=cert.tilt_limit_deg)
        tag = f"tracking bound: {name}"
        for case in ("no_feedforward", "feedforward"):
            rows.append({"name": f"{tag} {case.replace('_', ' ')}, |a_d| <= {tb.accel_limit_m_s2:g} m/s², "
                                 f"|jerk| <= {tb.jerk_limit_m_s3:g} m/s³ (nominal)",
                         "value": tb.bound_m[case], "unit": "m"})
        ok, _ = check_tracking_section(section_of_bound(tb, "nominal"), cert.vehicle, cert.gains, cert.inner_loop,
                                       rate_hz=rate, tilt_limit_deg=cert.tilt_limit_deg, box=None)
        rows.append({"name": f"{tag} recomputed as verify does", "value": float(ok), "unit": "bool", "target": "1",
                     "ok": ok})
        for (ax, ay), period, ff in FLIGHTS:
            ref = FigureEight(ax, ay, period)
            pos, vel, _ = ref.sample(0.0)
            opts = SimOptions(model="full", horizon_s=2 * period, tilt_limit_deg=cert.tilt_limit_deg, motor_lag=True,
                              inner=cert.inner_loop, controller_sampling="discrete", noise_rate_hz=rate,
                              reference=ref, feedforward=ff, xi0=tuple(pos[0]), v0=tuple(vel[0]))
            run_, = simulate(cert.vehicle, cert.gains, opts)
            err = float(np.max(np.linalg.norm(run_.xy - ref.sample(run_.t)[0], axis=1)))
            t = np.linspace(0.0, 2 * period, 20001)
            case = "feedforward" if ff else "no_feedforward"
            got = classify_reference(tb, t, *ref.sample(t), ref.jerk(t))
            what = f"{tag} figure-eight {ax:g}x{ay:g} m/{period:g} s, {case.replace('_', ' ')}"
            row = {"name": f"{what}: max error / bound", "value": err / got.bound_m[case], "unit": "ratio"}
            if got.inside[case]:
                row.update(target="<= 1", ok=bool(err <= got.bound_m[case]))
            else:
                row["name"] += " (outside the class or zone: " + "; ".join(got.reasons[case]) + ")"
            rows.append(row)
    return rows
