"""Regenerate the tuned designs, certificates and Monte Carlo families the notebooks read (docs/notes/laws.md).

    .venv/bin/python notebooks/data/make_data.py                # every step, in order
    .venv/bin/python notebooks/data/make_data.py families       # some steps

Every step but the last is one ``nniquad`` command, printed before it runs, run from this folder; each writes
its file atomically, so a stopped run leaves the old file.  The tuner and the studies are seeded, so the same
commands should give the same designs (the timing and software records differ); the committed files were made
once, not regenerated to check this.  On 2 idle cores a tuning step takes 3-5 minutes, ``families`` about 5.  The steps, in order (later ones read earlier ones):

``pd_velocity``, ``pd_filtered``
    The two PD comparison laws tuned by the same tuner on the same 20 robust scenarios (robust default, the
    discrete controller at the control rate, no margin requirement: a PD law has no NNI cascade of its own).
    ``designs/pd_*_held.json`` (no step) are the PD designs the speed study started from, ranked on the
    continuous controller on the held measurement (the 1.60 s and 1.93 s the speed study names);
    ``pd_filtered_held.json`` seeds the cascade-class steps below, as it did when their committed files were made.
``pd_filtered_paper``, ``pd_filtered_cascade``
    The filtered PD restricted to the designs whose NNI image lies in each law class, with the image's gain
    margins required as for the NNI law (as the speed study asked: "the best filtered PD whose image lies in
    that class").
``pd_image``
    The certificate of the unrestricted filtered PD's NNI image in the cascade class (does the
    sampled cascade certificate certify it?).
``nni_paper``, ``nni_cascade``, ``sni2_cascade``
    The certified designs (``nni_paper`` is not the committed ``full_model_certificate.json`` of
    ``nniquad certify --model full``, which the tests and notebooks 01-03 read): the NNI law in each class
    and the second-order SNI law in the cascade class, each seeded with the image of a filtered PD of the class (``nni_cascade`` and ``sni2_cascade``: the speed study's
    unrestricted filtered PD, whose image lies in the cascade class).
``nni_cascade_seeded``
    The cascade-class NNI design seeded with the image of the filtered PD of step ``pd_filtered`` (ranked as
    it flies; its image lies in the class and meets the gain margins), so it is never slower than that PD.
``sni2_cascade_seeded``
    The sni2 law in the cascade class seeded with the same PD's image (through the NNI law behind a fast
    low-pass, :func:`nniquad.laws.sni2.sni2_from_nni`).
``nni_cascade_no_margins``
    The cascade-class NNI design tuned without the gain-margin requirement, as the unrestricted filtered PD
    is (what the margins cost; a certificate of the class, not a design the notebooks recommend).
``pd_velocity_quiet``, ``pd_filtered_quiet``, ``pd_image_quiet``
    The two PD laws tuned again on the same robust set without position noise (``--scenario-noise-range 0 0``;
    every other perturbation the same), and the certificate of the quiet filtered PD's NNI image in the cascade
    class: what the 2 cm of noise in the corners costs a law that differentiates the measured position
    (notebook 03, section 6; docs/notes/robustness.md).
``sni2_paper``
    The second-order SNI law in the paper class (the sector bound ``k/(m kp ω²) <= γ_max``), unseeded: the
    fastest certified design that also keeps the paper's theorem and its 2.5 m certified reach
    (docs/notes/laws.md; ``benchmarks/bench_robust.py`` certifies it again and studies it).
``families``
    Notebook 03 section 5: every law's design run λ times faster and slower (``time_scaled``), each member
    on the nominal run and a small Monte Carlo study (:data:`FAMILY_LAMBDAS`, :data:`FAMILY_SAMPLES`,
    :data:`FAMILY_SEED`), written to ``families.json`` with the SHA-256 of every design file it read (the
    notebook refuses a families file older than its designs).
"""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
NNIQUAD = Path(sys.executable).with_name("nniquad")

#: step -> the nniquad arguments (paths relative to this folder).
STEPS: dict[str, list[str]] = {
    "pd_velocity": ["tune", "--model", "full", "--controller", "pd_velocity", "--json", "designs/pd_velocity.json"],
    "pd_filtered": ["tune", "--model", "full", "--controller", "pd_filtered", "--json", "designs/pd_filtered.json"],
    "pd_filtered_paper": ["tune", "--model", "full", "--controller", "pd_filtered", "--law-class", "paper",
                          "--json", "designs/pd_filtered_paper.json"],
    "pd_filtered_cascade": ["tune", "--model", "full", "--controller", "pd_filtered", "--law-class", "cascade",
                            "--json", "designs/pd_filtered_cascade.json"],
    "pd_image": ["certify", "--model", "full", "--law-class", "cascade", "--gains-from", "designs/pd_filtered.json",
                 "--out", "designs/pd_filtered_image_certificate.json"],
    "nni_paper": ["certify", "--model", "full", "--warm-start", "designs/pd_filtered_paper.json",
                  "--out", "paper_model_certificate.json"],
    "nni_cascade": ["certify", "--model", "full", "--law-class", "cascade",
                    "--warm-start", "designs/pd_filtered_held.json", "--out", "cascade_model_certificate.json"],
    "sni2_cascade": ["certify", "--model", "full", "--controller", "sni2", "--law-class", "cascade",
                     "--warm-start", "designs/pd_filtered_held.json", "--out", "sni2_cascade_certificate.json"],
    "nni_cascade_seeded": ["certify", "--model", "full", "--law-class", "cascade",
                           "--warm-start", "designs/pd_filtered.json",
                           "--out", "designs/nni_cascade_seeded_certificate.json"],
    "sni2_cascade_seeded": ["certify", "--model", "full", "--controller", "sni2", "--law-class", "cascade",
                            "--warm-start", "designs/pd_filtered.json",
                            "--out", "designs/sni2_cascade_seeded_certificate.json"],
    "pd_velocity_quiet": ["tune", "--model", "full", "--controller", "pd_velocity", "--scenario-noise-range", "0", "0",
                          "--json", "designs/pd_velocity_quiet.json"],
    "pd_filtered_quiet": ["tune", "--model", "full", "--controller", "pd_filtered", "--scenario-noise-range", "0", "0",
                          "--json", "designs/pd_filtered_quiet.json"],
    "pd_image_quiet": ["certify", "--model", "full", "--law-class", "cascade", "--scenario-noise-range", "0", "0",
                       "--gains-from", "designs/pd_filtered_quiet.json",
                       "--out", "designs/pd_filtered_quiet_image_certificate.json"],
    "nni_cascade_no_margins": ["certify", "--model", "full", "--law-class", "cascade", "--no-margins",
                               "--warm-start", "designs/pd_filtered_held.json",
                               "--out", "designs/nni_cascade_no_margins_certificate.json"],
    "sni2_paper": ["certify", "--model", "full", "--controller", "sni2", "--out", "designs/sni2_paper_certificate.json"],
}

#: The laws of notebook 03 section 5 -> the file of their design (a certificate or a 'tune --json' file).
FAMILY_DESIGNS: dict[str, str] = {
    "nni": "paper_model_certificate.json",
    "nni_cascade": "cascade_model_certificate.json",
    "sni2_cascade": "sni2_cascade_certificate.json",
    "sni2_paper": "designs/sni2_paper_certificate.json",
    "pd_velocity": "designs/pd_velocity.json",
    "pd_filtered": "designs/pd_filtered.json",
}
#: Time-scale factors of each family: up to where the attitude loop can no longer follow.
FAMILY_LAMBDAS = (0.6, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5)
#: Monte Carlo scenarios per family member and their seed.
FAMILY_SAMPLES, FAMILY_SEED = 24, 2026
#: Horizon of the nominal run of a family member [s].
FAMILY_HORIZON_S = 20.0
FAMILIES_FILE = "families.json"


def sha256_of(path: Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load_design(relpath: str):
    """(gains block, inner loops) of a certificate or a 'tune --json' file in this folder."""
    from nniquad import InnerLoopGains, read_certificate
    from nniquad.laws import law_named

    path = HERE / relpath
    data = json.loads(path.read_text())
    if data.get("schema") is not None:
        cert = read_certificate(path)
        return cert.gains, cert.inner_loop
    return law_named(data["controller"]).gains(data["gains"]), InnerLoopGains(**data["inner_loop"])


def families() -> dict:
    """Every family member of :data:`FAMILY_DESIGNS`: nominal settling, peak tilt, Monte Carlo success."""
    from nniquad import (PAPER_VEHICLE as V, SimOptions, montecarlo, settling_shown, simulate, study_setup_from)

    rows = []
    base = SimOptions(model="full", horizon_s=FAMILY_HORIZON_S, motor_lag=True, controller_sampling="discrete",
                      noise_rate_hz=100.0)
    for law, rel in FAMILY_DESIGNS.items():
        g0, inner = load_design(rel)
        for lam in FAMILY_LAMBDAS:
            g = g0.time_scaled(lam)
            met = simulate(V, g, base.with_(inner=inner))[0].metrics()
            s_nom = met.settling_s if (not met.diverged and settling_shown(met.settling_s, FAMILY_HORIZON_S)) else None
            mc = montecarlo(study_setup_from(V, g, inner=inner, tilt_limit_deg=base.tilt_limit_deg),
                            samples=FAMILY_SAMPLES, seed=FAMILY_SEED, workers=1)
            sm = mc.summary
            rows.append({"law": law, "lam": lam, "controller": g.controller,
                         "gains": {k: v for k, v in g.as_dict().items() if v is not None},
                         "nominal_s": s_nom, "peak_tilt_deg": met.peak_tilt_deg, "success": sm.success_rate,
                         "success_ci": list(sm.success_ci), "p95_s": sm.settling["p95"][0]})
            print(f"  {law} λ={lam:g}: nominal {s_nom} s, success {100 * sm.success_rate:.0f} %", flush=True)
    return {"lambdas": list(FAMILY_LAMBDAS), "samples": FAMILY_SAMPLES, "seed": FAMILY_SEED,
            "horizon_s": FAMILY_HORIZON_S, "controller_sampling": "discrete", "control_rate_hz": 100.0,
            "designs": {law: {"file": rel, "sha256": sha256_of(HERE / rel)} for law, rel in FAMILY_DESIGNS.items()},
            "rows": rows}


def write_json_atomically(path: Path, doc: dict) -> None:
    """Write ``doc`` to ``path`` through a temporary file in the same folder (no partial file is left)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o644)  # mkstemp's 0600 would hide the data from other users of the checkout
        with os.fdopen(fd, "w") as fh:
            json.dump(doc, fh, indent=1)
            fh.write("\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def main(argv: list[str]) -> int:
    """Run the named steps (all without arguments); exit status of the first that fails, else 0."""
    names = [*STEPS, "families"]
    unknown = [a for a in argv if a not in names]
    if unknown:
        print(f"make_data: unknown step {unknown[0]!r} (steps: {', '.join(names)})", file=sys.stderr)
        return 2
    for name in argv or names:
        if name == "families":
            print(f"[families] (python: writes {HERE / FAMILIES_FILE})", flush=True)
            write_json_atomically(HERE / FAMILIES_FILE, families())
            continue
        cmd = [str(NNIQUAD), *STEPS[name]]
        print(f"[{name}] (cd {HERE} && {' '.join(shlex.quote(c) for c in cmd)})", flush=True)
        code = subprocess.call(cmd, cwd=HERE)
        if code:
            print(f"make_data: step {name} failed with exit status {code}", file=sys.stderr)
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
