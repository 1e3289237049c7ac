"""RotorPy against the project: the 2 % settling time of a certificate flown in both simulators.

For four committed certificates (two of the NNI law, two of ``sni2``) and each
attitude loop of :data:`nniquad.integrations.rotorpy.ATTITUDE_MODES`, one RotorPy
flight (:func:`nniquad.integrations.rotorpy.fly_certificate`) and the project's
``full`` run with the certificate's settings; rows are both settling times and
their ratio, and both overshoots.  The target (within 2 %) applies to the loops the certificate
assumes: RotorPy's own loop at the certificate's bandwidth and damping, and the
certificate's own attitude law; RotorPy's default gains are measured, not
certified.  Full: RotorPy stepped at 1 kHz (the project's integration step);
``--quick``: at 500 Hz.  A machine without RotorPy (a dev dependency) gives no rows.

Usage: ``python benchmarks/bench_rotorpy.py [--quick]`` prints the rows.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

__all__ = ["run"]

ROOT = Path(__file__).resolve().parent.parent
CERTIFICATES = {"nni cascade": ROOT / "notebooks/data/cascade_model_certificate.json",
                "nni full": ROOT / "notebooks/data/full_model_certificate.json",
                "sni2 cascade": ROOT / "notebooks/data/sni2_cascade_certificate.json",
                "sni2 paper": ROOT / "notebooks/data/designs/sni2_paper_certificate.json"}
#: Flight length [s]: long enough for RotorPy's default attitude gains to settle too.
HORIZON_S = 5.0
#: Target: settling within 2 % of the project's run, for the loops the certificate assumes.
SETTLING_RTOL = 0.02
CERTIFIED_MODES = ("rotorpy", "certificate")


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    try:
        import rotorpy  # noqa: F401  (a dev dependency)
    except ImportError:
        print("[bench] rotorpy: RotorPy is not installed (pip install 'rotorpy==3.0.0'), no rows", file=sys.stderr)
        return []
    from nniquad.certificates.certificate import PERFORMANCE_OUTPUT_DT_S, read_certificate
    from nniquad.certificates.export import certified_rate_hz
    from nniquad.integrations.rotorpy import ATTITUDE_MODES, fly_certificate
    from nniquad.sim import SimOptions, simulate

    sim_rate = 500.0 if quick else 1000.0
    rows = []
    for law, path in CERTIFICATES.items():
        cert = read_certificate(path)
        opts = SimOptions(model="full", horizon_s=HORIZON_S, output_dt_s=PERFORMANCE_OUTPUT_DT_S,
                          tilt_limit_deg=cert.tilt_limit_deg, xi0=tuple(cert.xi0_m), motor_lag=True,
                          inner=cert.inner_loop, controller_sampling="discrete", noise_rate_hz=certified_rate_hz(cert))
        met = simulate(cert.vehicle, cert.gains, opts)[0].metrics()
        ours = met.settling_s
        rows.append({"name": f"rotorpy: {law} project full run settling", "value": ours, "unit": "s"})
        rows.append({"name": f"rotorpy: {law} project full run overshoot", "value": met.overshoot_pct, "unit": "%"})
        for mode in ATTITUDE_MODES:
            t0 = time.perf_counter()
            flight = fly_certificate(cert, horizon_s=HORIZON_S, attitude=mode, sim_rate_hz=sim_rate)
            wall = time.perf_counter() - t0
            theirs = flight.settling_s
            ratio = float("nan") if theirs is None else theirs / ours
            rows.append({"name": f"rotorpy: {law} {mode} settling ({sim_rate:g} Hz)",
                         "value": float("nan") if theirs is None else theirs, "unit": "s"})
            rows.append({"name": f"rotorpy: {law} {mode} overshoot", "value": flight.overshoot_pct, "unit": "%"})
            row = {"name": f"rotorpy: {law} {mode} / project", "value": ratio, "unit": "ratio"}
            if mode in CERTIFIED_MODES:
                row.update(target=f"1 +- {SETTLING_RTOL:g}", ok=abs(ratio - 1.0) <= SETTLING_RTOL)
            rows.append(row)
            rows.append({"name": f"rotorpy: {law} {mode} flight wall time", "value": wall, "unit": "s"})
    return rows


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "design"))
    for r in run(quick="--quick" in sys.argv[1:]):
        print(f"{r['name']:<58} {r['value']:>10.4f} {r['unit']:<6} {r.get('target', '')} "
              f"{'' if 'ok' not in r else ('ok' if r['ok'] else 'MISSED')}")
