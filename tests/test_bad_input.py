"""Bad input, table-driven: every case ends in a non-zero exit, one line naming the problem, no traceback, no file.

Classes: input files (vehicle, certificate), values that overflow or
mislead, output paths, resource requests, late validation.  Every case runs
in-process and fails before any simulation starts, so the whole table takes
seconds.  The expected word is what a user must see in the message; the
files of the test folder (the working directory) are compared before and
after, so no case may leave anything behind.
"""

from __future__ import annotations

import json
import re
import os
from pathlib import Path

import pytest

from nniquad.certificates.certificate import canonical_digest
from nniquad.model.vehicle import PAPER_VEHICLE

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"
V = PAPER_VEHICLE.as_dict()
DEEP = 200_000


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A working folder with the fixtures bad paths need; the machine is said to have 16 GiB available."""
    import nniquad.resources as resources

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(resources, "available_memory_bytes", lambda: 16 * 2**30)
    (tmp_path / "afile").write_text("I am a file\n")
    (tmp_path / "adir").mkdir()
    return tmp_path


def check_clean(run_cli, root: Path, argv: list[str], word: str, code: int = 2) -> str:
    """Run ``nniquad argv``; assert the exit status, one error line containing ``word``, no traceback, no new file."""
    before = _tree(root)
    rc, out, err = run_cli(*argv)
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("[")]
    assert rc == code, (argv, rc, err)
    assert "Traceback" not in err and "Traceback" not in out, err
    assert len(lines) == 1, (argv, err)
    assert word.lower() in lines[0].lower(), (argv, word, lines[0])
    assert lines[0].startswith("nniquad") and ": error: " in lines[0]
    assert _tree(root) == before, (argv, _tree(root) ^ before)
    return lines[0]


# ============================================================================ vehicle files


def _vjson(**changes) -> bytes:
    return json.dumps({**V, **changes}).encode()


def _vtoml(**raw: str) -> bytes:
    """The paper's vehicle as TOML, with some values given as raw TOML text."""
    lines = []
    for k, v in V.items():
        lines.append(f"{k} = {raw.pop(k)}" if k in raw else f"{k} = {json.dumps(v)}")
    lines += [f"{k} = {v}" for k, v in raw.items()]
    return ("\n".join(lines) + "\n").encode()


_GOOD_TOML = _vtoml()
VEHICLE_CASES = [
    # (id, file name, content, word)
    ("binary", "v.json", bytes(range(256)) * 4, "binary"),
    ("nul-in-json", "v.json", _vjson()[:20] + b"\x00" + _vjson()[20:], "binary"),
    ("elf-header", "v.toml", b"\x7fELF\x02\x01\x01\x00" + b"\x00" * 64, "binary"),
    ("utf16-le-bom", "v.json", _vjson().decode().encode("utf-16"), "UTF-16"),
    ("utf16-be-bom", "v.toml", b"\xfe\xff" + _GOOD_TOML.decode().encode("utf-16-be"), "UTF-16"),
    ("utf16-no-bom", "v.json", _vjson().decode().encode("utf-16-le"), "UTF-16"),
    ("utf32", "v.json", _vjson().decode().encode("utf-32"), "UTF-32"),
    ("latin1", "v.toml", _GOOD_TOML.replace(b'name = "', b'name = "caf\xe9 '), "not UTF-8"),
    ("bad-continuation", "v.json", b'{"name": "\xc3\x28"}', "not UTF-8"),
    ("surrogate-bytes", "v.toml", b'name = "\xed\xa0\x80"\n', "not UTF-8"),
    ("deep-json-arrays", "v.json", b"[" * DEEP + b"]" * DEEP, "nested"),
    ("deep-json-objects", "v.json", b'{"a":' * DEEP + b"1" + b"}" * DEEP, "nested"),
    ("deep-json-unclosed", "v.json", b"[" * DEEP, "not valid JSON"),
    ("deep-toml-arrays", "v.toml", b"m = " + b"[" * DEEP + b"]" * DEEP + b"\n", "nested"),
    ("deep-toml-tables", "v.toml", b"m = " + b"{a = " * 5000 + b"1" + b"}" * 5000 + b"\n", "nested"),
    ("json-nested-100", "v.json", b'{"m": ' + b"[" * 100 + b"]" * 100 + b"}", "nested"),
    ("json-5000-digits", "v.json", _vjson().replace(b'"m": 0.5', b'"m": ' + b"7" * 5000), "digits"),
    ("json-5000-digits-neg", "v.json", _vjson().replace(b'"m": 0.5', b'"m": -' + b"7" * 5000), "digits"),
    ("toml-5000-digits", "v.toml", _vtoml(m="7" * 5000), "digits"),
    ("json-401-digit-m", "v.json", _vjson().replace(b'"m": 0.5', b'"m": ' + b"9" * 401), "float"),
    ("toml-401-digit-m", "v.toml", _vtoml(m="9" * 401), "float"),
    ("toml-401-digit-negative", "v.toml", _vtoml(m="-" + "9" * 401), "float"),
    ("json-omega-1e300", "v.json", _vjson(omega_max=1e300), "thrust"),
    ("toml-omega-1e300", "v.toml", _vtoml(omega_max="1e300"), "thrust"),
    ("toml-b-1e300", "v.toml", _vtoml(b="1e300", omega_max="1e200"), "thrust"),
    ("json-hover-overflow", "v.json", _vjson(m=1e300, g=1e10, b=1e-300), "weight"),
    ("json-drag-overflow", "v.json", _vjson(d=1e100, omega_max=1e200, b=1e-300), "thrust"),
    ("json-float-1e999", "v.json", _vjson().replace(b'"m": 0.5', b'"m": 1e999'), "finite"),
    ("json-duplicate-m", "v.json", _vjson()[:-1] + b', "m": 5.0}', "duplicate"),
    ("json-duplicate-name", "v.json", b'{"name": "a", "name": "b"}', "duplicate"),
    ("json-duplicate-nested", "v.json", b'{"m": {"a": 1, "a": 2}}', "duplicate"),
    ("toml-duplicate-m", "v.toml", _GOOD_TOML + b"m = 5.0\n", "m"),
    ("json-top-list", "v.json", b"[1, 2, 3]", "table of fields"),
    ("json-top-string", "v.json", b'"vehicle"', "table of fields"),
    ("json-top-number", "v.json", b"0.5", "table of fields"),
    ("json-top-null", "v.json", b"null", "table of fields"),
    ("json-empty", "v.json", b"", "not valid JSON"),
    ("json-whitespace", "v.json", b"  \n\t ", "not valid JSON"),
    ("json-truncated", "v.json", _vjson()[:-10], "not valid JSON"),
    ("json-trailing-garbage", "v.json", _vjson() + b" extra", "not valid JSON"),
    ("toml-syntax", "v.toml", b"m = = 1\n", "not valid TOML"),
    ("toml-bad-date", "v.toml", _GOOD_TOML + b"when = 1979-02-30\n", "TOML"),
    ("toml-empty", "v.toml", b"", "missing field"),
    ("toml-control-char", "v.toml", b'name = "a\x01b"\n', "TOML"),
    ("unknown-field", "v.json", _vjson(colour="red"), "unknown field"),
    ("missing-field", "v.toml", b"m = 0.5\n", "missing field"),
    ("m-string", "v.json", _vjson(m="heavy"), "must be a number"),
    ("m-bool", "v.toml", _vtoml(m="true"), "must be a number"),
    ("m-list", "v.json", _vjson(m=[0.5]), "must be a number"),
    ("m-table", "v.toml", _vtoml(m="{ value = 0.5 }"), "must be a number"),
    ("m-null", "v.json", _vjson(m=None), "must be a number"),
    ("m-nan-json", "v.json", _vjson().replace(b'"m": 0.5', b'"m": NaN'), "finite"),
    ("m-inf-json", "v.json", _vjson().replace(b'"m": 0.5', b'"m": -Infinity'), "finite"),
    ("g-inf-toml", "v.toml", _vtoml(g="inf"), "finite"),
    ("g-nan-toml", "v.toml", _vtoml(g="nan"), "finite"),
    ("m-zero", "v.json", _vjson(m=0), "positive"),
    ("m-negative-zero", "v.toml", _vtoml(m="-0.0"), "positive"),
    ("Jz-negative", "v.json", _vjson(Jz=-1e-3), "positive"),
    ("name-number", "v.json", _vjson(name=5), "string"),
    ("triangle", "v.json", _vjson(Jz=1.0), "triangle"),
    ("cannot-hover", "v.toml", _vtoml(omega_max="100.0"), "hover"),
    ("tiny-subnormal-b", "v.json", _vjson(b=5e-324), "hover"),
    ("yaml-extension", "v.yaml", b"m: 1\n", "unsupported extension"),
    ("no-extension", "vehicle", _vjson(), "unsupported extension"),
    ("too-large", "v.json", b" " * (16 * 2**20 + 1), "more than"),
]


@pytest.mark.parametrize("name, content, word", [c[1:] for c in VEHICLE_CASES], ids=[c[0] for c in VEHICLE_CASES])
def test_bad_vehicle_file(run_cli, work, name, content, word):
    (work / name).write_bytes(content)
    line = check_clean(run_cli, work, ["vehicle", "--vehicle", name], word)
    assert name in line  # the message names the file


@pytest.mark.parametrize("make, word", [
    (lambda p: os.mkfifo(p), "FIFO"),
    (lambda p: os.symlink("/dev/zero", p), "character device"),
    (lambda p: os.symlink("/dev/urandom", p), "character device"),
    (lambda p: p.mkdir(), "folder"),
    (lambda p: os.symlink(p.parent / "missing.json", p), "No such file"),
    (lambda p: None, "No such file"),
], ids=["fifo", "dev-zero", "dev-urandom", "folder", "dangling-link", "missing"])
@pytest.mark.parametrize("command", [["vehicle"], ["lmi"], ["simulate", "--model", "linear"]], ids=lambda c: c[0])
def test_vehicle_not_a_regular_file(run_cli, work, make, word, command):
    """A FIFO must not block (the reader opens non-blocking), a device must not be read at all."""
    p = work / "v.json"
    make(p)
    check_clean(run_cli, work, [*command, "--vehicle", str(p)], word)


# ============================================================================ certificates


def _cert() -> dict:
    return json.loads(CERT.read_text())


def _signed(edit=None) -> bytes:
    c = _cert()
    if edit is not None:
        edit(c)
    c["digest"]["value"] = canonical_digest(c)
    return json.dumps(c).encode()


_CERT_TEXT = CERT.read_bytes()
CERT_CASES = [
    # (id, content, word, exit status)
    ("binary", os.urandom(4096).replace(b"\x00", b"\x01") + b"\x00", "binary", 2),
    ("utf16", _CERT_TEXT.decode().encode("utf-16"), "UTF-16", 2),
    ("utf16-no-bom", _CERT_TEXT.decode().encode("utf-16-be"), "UTF-16", 2),
    ("latin1", _CERT_TEXT.replace(b'"schema"', b'"sch\xe9ma"', 1), "not UTF-8", 2),
    ("deep", b"[" * DEEP + b"]" * DEEP, "nested", 2),
    ("deep-objects", b'{"a":' * DEEP + b"0" + b"}" * DEEP, "nested", 2),
    ("deep-inside-signed", _signed(lambda c: c.__setitem__("x", json.loads("[" * 80 + "]" * 80))), "nested", 2),
    ("5000-digits", re.sub(rb'"schema_version": \d+', b'"schema_version": ' + b"1" * 5000, _CERT_TEXT), "digits", 2),
    ("401-digits-signed", _signed(lambda c: c["gains"].__setitem__("kp", 10**400)), "float", 2),
    ("duplicate-top", _CERT_TEXT.replace(b"{", b'{"schema": "nniquad-certificate",', 1), "duplicate", 2),
    ("duplicate-gains", _signed().replace(b'"gains": {', b'"gains": {"kp": 1e6, ', 1), "duplicate", 2),
    ("empty", b"", "not valid JSON", 2),
    ("truncated", _CERT_TEXT[: len(_CERT_TEXT) // 2], "not valid JSON", 2),
    ("top-list", b"[]", "top level", 2),
    ("top-null", b"null", "top level", 2),
    ("wrong-schema", _signed(lambda c: c.__setitem__("schema", "other")), "schema", 2),
    ("future-version", _signed(lambda c: c.__setitem__("schema_version", 99)), "version", 2),
    ("no-digest", json.dumps({k: v for k, v in _cert().items() if k != "digest"}).encode(), "no digest", 2),
    ("digest-not-text", json.dumps({**_cert(), "digest": {"algorithm": "sha256", "value": 0}}).encode(), "no digest", 2),
    ("nan-resigned", _CERT_TEXT.replace(b'"tilt_limit_deg": 30.0', b'"tilt_limit_deg": NaN', 1), "canonicalised", 2),
    ("malformed-gains", _signed(lambda c: c.__setitem__("gains", "fast")), "gains", 2),
    ("malformed-vehicle", _signed(lambda c: c["vehicle"].__setitem__("m", -1)), "positive", 2),
    ("vehicle-overflow", _signed(lambda c: c["vehicle"].__setitem__("omega_max", 1e300)), "thrust", 2),
    ("digest-mismatch", _CERT_TEXT.replace(b'"kp": ', b'"kp": 1', 1), "digest mismatch", 1),
    ("tampered-one-bit", _CERT_TEXT.replace(b'"tilt_limit_deg": 30.0', b'"tilt_limit_deg": 30.1', 1),
     "digest mismatch", 1),
    ("too-large", b" " * (16 * 2**20 + 1), "more than", 2),
]


@pytest.mark.parametrize("content, word, code", [c[1:] for c in CERT_CASES], ids=[c[0] for c in CERT_CASES])
def test_bad_certificate_verify(run_cli, work, content, word, code):
    (work / "c.json").write_bytes(content)
    check_clean(run_cli, work, ["verify", "c.json", "--no-simulate"], word, code)


@pytest.mark.parametrize("content, word, code", [c[1:] for c in CERT_CASES if c[0] in
                                                 ("binary", "utf16", "deep", "5000-digits", "duplicate-top",
                                                  "digest-mismatch", "401-digits-signed")],
                         ids=["binary", "utf16", "deep", "5000-digits", "401-digits", "duplicate", "digest"])
@pytest.mark.parametrize("command", [["simulate", "--model", "linear", "--horizon", "1"],
                                     ["montecarlo", "--samples", "2"]], ids=lambda c: c[0])
def test_bad_certificate_as_input(run_cli, work, content, word, code, command):
    (work / "c.json").write_bytes(content)
    check_clean(run_cli, work, [*command, "--certificate", "c.json"], word, code)


@pytest.mark.parametrize("make, word", [
    (lambda p: os.mkfifo(p), "FIFO"),
    (lambda p: os.symlink("/dev/zero", p), "character device"),
    (lambda p: p.mkdir(), "folder"),
], ids=["fifo", "dev-zero-link", "folder"])
def test_certificate_not_a_regular_file(run_cli, work, make, word):
    make(work / "c.json")
    check_clean(run_cli, work, ["verify", "c.json"], word)


def test_verify_dev_zero_directly(run_cli, work):
    check_clean(run_cli, work, ["verify", "/dev/zero"], "character device")


# ============================================================================ output paths

#: (command before the output option, the option, whether it names a folder)
OUTPUT_SLOTS = [
    (["vehicle"], "--write", False),
    (["simulate", "--model", "linear", "--horizon", "0.1"], "--json", False),
    (["simulate", "--model", "linear", "--horizon", "0.1"], "--trajectory", False),
    (["simulate", "--model", "linear", "--horizon", "0.1"], "--plot", False),
    (["verify", str(CERT), "--no-simulate"], "--json", False),
    (["lmi"], "--json", False),
    (["bound"], "--json", False),
    (["derive"], "--out", False),
    (["prove", "--only", "ni_lemma"], "--json", False),
    (["prove", "--only", "ni_lemma"], "--markdown", False),
    (["tune", "--budget", "quick"], "--json", False),
    (["certify", "--kp", "5", "--Gamma", "160", "--delta", "0.6"], "--out", False),
    (["montecarlo", "--certificate", str(CERT), "--samples", "2"], "--json", False),
]
BAD_FILES = [
    ("file-as-folder", "afile/x.json", "afile is a file, not a folder"),
    ("file-as-folder-deep", "afile/sub/x.json", "not a folder"),
    ("trailing-slash", "somedir/", "names a folder"),
    ("existing-folder", "adir", "is a folder"),
    ("proc", "/proc/x.json", "cannot create a file in /proc"),
    ("proc-missing-parent", "/proc/nniquad/x/y.json", "cannot create a file in /proc"),
    ("dev-null", "/dev/null", "character device"),
    ("empty", "", "needs a file name"),
]


@pytest.mark.parametrize("path, word", [b[1:] for b in BAD_FILES], ids=[b[0] for b in BAD_FILES])
@pytest.mark.parametrize("command, option, _folder", OUTPUT_SLOTS,
                         ids=[f"{c[0]}{o}" for c, o, _ in OUTPUT_SLOTS])
def test_bad_output_path_refused_before_work(run_cli, work, command, option, _folder, path, word):
    line = check_clean(run_cli, work, [*command, option, path], word)
    assert option in line  # names the option


@pytest.mark.parametrize("path, word", [
    ("afile", "is a file"),
    ("afile/sub", "not a folder"),
    ("/proc/report", "cannot create a file in /proc"),
    ("/dev/null", "character device"),
    ("", "needs a folder name"),
    (".", "current folder"),
    ("..", "folder of its own"),
], ids=["file", "under-file", "proc", "dev-null", "empty", "cwd", "parent"])
def test_bad_report_folder(run_cli, work, path, word):
    check_clean(run_cli, work, ["report", "--budget", "quick", "--out", path], word)


@pytest.mark.parametrize("path, word", [
    ("afile", "is a file"),
    ("afile/sub", "not a folder"),
    ("/proc/export", "cannot create a file in /proc"),
    ("/dev/null", "character device"),
    ("", "needs a folder name"),
], ids=["file", "under-file", "proc", "dev-null", "empty"])
def test_bad_export_folder(run_cli, work, path, word):
    check_clean(run_cli, work, ["export", str(CERT), "--out", path], word)


@pytest.mark.parametrize("argv, word", [
    (["simulate", "--model", "linear", "--horizon", "0.1", "--json", "a.json", "--trajectory", "a.json"], "same file"),
    (["simulate", "--model", "linear", "--horizon", "0.1", "--json", "a.json", "--plot", "a.traj.npz"], "same file"),
    (["simulate", "--model", "linear", "--horizon", "0.1", "--json", "out.json", "--plot", "/proc/p.png"], "--plot"),
    (["simulate", "--model", "linear", "--horizon", "0.1", "--json", "afile/o.json", "--plot", "p.png"], "--json"),
    (["simulate", "--model", "linear", "--horizon", "0.1", "--trajectory", "t.txt"], ".npz or .csv"),
    (["prove", "--only", "ni_lemma", "--json", "a.md", "--markdown", "a.md"], "same file"),
    (["montecarlo", "--certificate", str(CERT), "--samples", "2", "--json", "adir/../afile/m.json"], "not a folder"),
], ids=["json-is-trajectory", "plot-is-derived-trajectory", "plot-in-proc", "json-under-file", "bad-suffix",
        "json-is-markdown", "montecarlo-under-file"])
def test_outputs_checked_together(run_cli, work, argv, word):
    check_clean(run_cli, work, argv, word)


def test_montecarlo_partial_file_checked_before_the_study(run_cli, work):
    (work / "m.partial.json").mkdir()  # where an interrupted study would save its batches
    check_clean(run_cli, work, ["montecarlo", "--certificate", str(CERT), "--samples", "2", "--json", "m.json"],
                "partial")


def test_failed_plot_leaves_no_trajectory(run_cli, work, monkeypatch):
    """All or nothing: the plot fails after the trajectory was written -> neither file appears."""
    import nniquad.sim.plots as plots

    def broken(traj, path):
        from nniquad.io import atomic_write_with

        def half(tmp):
            tmp.write_bytes(b"\x89PNG half")
            raise OSError(28, "No space left on device", str(path))

        atomic_write_with(path, half)

    monkeypatch.setattr(plots, "trajectory_plot", broken)
    check_clean(run_cli, work, ["simulate", "--model", "linear", "--horizon", "0.1", "--json", "sub/out.json",
                                "--plot", "sub/p.png"], "No space left")
    assert not (work / "sub").exists()  # the folder the writes created is gone too


# ============================================================================ values, options, resources

C = str(CERT)
OPTION_CASES = [
    # simulate: overflow, misleading values, resources
    (["simulate", "--horizon", "1e9"], "TiB"),
    (["simulate", "--horizon", "1e6"], "GiB"),
    (["simulate", "--model", "linear", "--horizon", "1e7"], "GiB"),
    (["simulate", "--horizon", "1e400"], "finite"),
    (["simulate", "--horizon", "nan"], "finite"),
    (["simulate", "--horizon", "-1"], "positive"),
    (["simulate", "--horizon", "0"], "positive"),
    (["simulate", "--horizon", "ten"], "invalid float"),
    (["simulate", "--dt", "0"], "positive"),
    (["simulate", "--dt", "1e-12", "--output-dt", "1e-12", "--rate", "1"], "memory"),
    (["simulate", "--dt", "0.01", "--output-dt", "0.001"], "multiple"),
    (["simulate", "--dt", "1", "--output-dt", "1", "--rate", "1"], "too large"),
    (["simulate", "--attitude-wn", "1e6"], "attitude pole"),
    (["simulate", "--attitude-wn", "5000"], "--attitude-wn"),
    (["simulate", "--attitude-wn", "1e300"], "attitude"),
    (["simulate", "--attitude-wn", "nan"], "attitude_wn"),
    (["simulate", "--attitude-wn", "-25"], "attitude_wn"),
    (["simulate", "--attitude-wn", "0"], "attitude_wn"),
    (["simulate", "--attitude-zeta", "1e6"], "attitude pole"),
    (["simulate", "--attitude-zeta", "inf"], "attitude_zeta"),
    (["simulate", "--motor-lag", "--tau-motor", "1e-9"], "motor lag"),
    (["simulate", "--motor-lag", "--tau-motor", "1e-4"], "--tau-motor"),
    (["simulate", "--tau-motor", "-1"], "motor time constant"),
    (["simulate", "--rate", "1e9"], "sample rate"),
    (["simulate", "--rate", "0"], "rate"),
    (["simulate", "--noise", "-1"], "noise"),
    (["simulate", "--noise", "nan"], "noise"),
    (["simulate", "--seed", "-1"], "seed"),
    (["simulate", "--seed", "1.5"], "invalid int"),
    (["simulate", "--seed", "9" * 5000], "invalid int"),
    (["simulate", "--xi0", "nan", "0"], "xi0"),
    (["simulate", "--xi0", "1e400", "0"], "xi0"),
    (["simulate", "--wind", "inf", "0"], "wind"),
    (["simulate", "--gust", "-1"], "gust"),
    (["simulate", "--gust-tau", "0"], "gust correlation"),
    (["simulate", "--true-mass", "0"], "true mass"),
    (["simulate", "--true-mass", "1e400"], "true mass"),
    (["simulate", "--tilt-limit", "90"], "tilt limit"),
    (["simulate", "--tilt-limit", "-5"], "tilt limit"),
    (["simulate", "--kp", "1e400"], "kp"),
    (["simulate", "--kp", "-5"], "kp"),
    (["simulate", "--Gamma", "nan"], "Gamma"),
    (["simulate", "--delta", "0"], "delta"),
    (["simulate", "--Gamma", "1e6"], "Gamma*delta"),
    (["simulate", "--model", "quantum"], "invalid choice"),
    (["simulate", "--certificate", C, "--kp", "3"], "not both"),
    # lmi / bound
    (["lmi", "--kp", "abc"], "kp"),
    (["lmi", "--kp", "1e400"], "kp"),
    (["lmi", "--delta", "-1"], "delta"),
    (["lmi", "--mass-range", "2", "1"], "mass-range"),
    (["lmi", "--mass-range", "nan", "1"], "mass-range"),
    (["lmi", "--tilt-limit-deg", "inf"], "tilt"),
    (["bound", "--tilt-limit-deg", "95"], "tilt"),
    (["bound", "--tilt-limit-deg", "nan"], "tilt"),
    (["bound", "--xi0", "nan", "0"], "xi0"),
    # montecarlo
    (["montecarlo", "--certificate", C, "--samples", "1000000000000"], "PiB"),
    (["montecarlo", "--certificate", C, "--samples", "0"], "--samples"),
    (["montecarlo", "--certificate", C, "--samples", "-5"], "--samples"),
    (["montecarlo", "--certificate", C, "--samples", "1e3"], "invalid int"),
    (["montecarlo", "--certificate", C, "--samples", "10", "--workers", "0"], "--workers"),
    (["montecarlo", "--certificate", C, "--samples", "10", "--workers", "100000"], "--workers 100000"),
    (["montecarlo", "--certificate", C, "--samples", "10", "--batch-size", "0"], "--batch-size"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--horizon", "1e9"], "TiB"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--horizon", "-1"], "--horizon"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--horizon", "inf"], "--horizon"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--seed", "-1"], "--seed"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--worst", "-1"], "--worst"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--mass-range", "0", "1"], "mass"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--mass-range", "1.2", "0.8"], "mass"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--tau-motor-range", "0.0001", "0.01"], "motor"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--attitude-gain-range", "1", "1e12"],
     "--attitude-gain-range"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--noise-range", "-1", "0"], "noise"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--wind-range", "nan", "1"], "wind"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--altitude-limit", "0"], "altitude"),
    (["montecarlo", "--certificate", C, "--rerun", "abc"], "--rerun"),
    (["montecarlo", "--certificate", C, "--rerun", "-1"], "--rerun"),
    (["montecarlo", "--certificate", C, "--samples", "2", "--scheduler", "tcp://x:1", "--workers", "2"], "--workers"),
    # tune / certify / report: refused before the audit or the search starts
    (["tune", "--reruns", "-5"], "reruns"),
    (["tune", "--gamma-max", "1.5"], "gamma_max"),
    (["tune", "--gamma-max", "nan"], "gamma_max"),
    (["tune", "--roa-radius", "-1"], "roa"),
    (["tune", "--tilt-limit", "100"], "tilt limit"),
    (["tune", "--noise", "-1"], "noise"),
    (["tune", "--mass-range", "2", "1"], "mass range"),
    (["tune", "--model", "full", "--scenario-noise-range", "0.03", "0.01"], "scenario noise range"),
    (["tune", "--model", "full", "--scenario-noise-range", "-0.01", "0.01"], "scenario noise range"),
    (["tune", "--model", "full", "--scenario-noise-range", "0", "inf"], "scenario noise range"),
    (["tune", "--scenario-noise-range", "0", "0"], "--model full"),
    (["tune", "--model", "full", "--nominal", "--scenario-noise-range", "0", "0"], "--model full"),
    (["certify", "--model", "full", "--scenario-noise-range", "0.02", "0", "--out", "c.json"], "scenario noise range"),
    (["tune", "--seed", "-3"], "seed"),
    (["tune", "--budget", "infinite"], "invalid choice"),
    (["certify", "--kp", "5", "--Gamma", "160", "--out", "c.json"], "--delta"),
    (["certify", "--kp", "nan", "--Gamma", "160", "--delta", "0.6", "--out", "c.json"], "kp"),
    (["certify", "--kp", "5", "--Gamma", "160", "--delta", "0.1", "--out", "c.json"], "sector"),
    (["certify", "--kp", "5", "--Gamma", "160", "--delta", "0.6", "--attitude-wn", "1e6", "--out", "c.json"],
     "attitude pole"),
    (["certify", "--reruns", "-1", "--out", "c.json"], "reruns"),
    (["report", "--reruns", "-5", "--out", "r"], "reruns"),
    (["report", "--gamma-max", "1.2", "--out", "r"], "gamma"),
    (["report", "--roa-radius", "-1", "--out", "r"], "roa"),
    (["report", "--budget", "forever", "--out", "r"], "invalid choice"),
    (["report", "--model", "linear", "--out", "r"], "invalid choice"),
    # the top level
    (["prove", "--only", "no_such_claim"], "unknown claim"),
    (["derive", "--variant", "odd"], "invalid choice"),
    (["nonsense"], "invalid choice"),
    (["simulate", "--no-such-option"], "unrecognized"),
]


@pytest.mark.parametrize("argv, word", OPTION_CASES, ids=[" ".join(a)[:60] for a, _ in OPTION_CASES])
def test_bad_option_refused_before_work(run_cli, work, argv, word):
    check_clean(run_cli, work, argv, word)


def test_report_reruns_refused_at_once_and_leaves_nothing(run_cli, work):
    import time

    t0 = time.perf_counter()
    check_clean(run_cli, work, ["report", "--reruns", "-5", "--out", "r"], "reruns")
    assert time.perf_counter() - t0 < 5.0  # refused before the audit (8 s of work before the fix)


def test_the_case_count_is_the_one_reported():
    """At least 150 distinct bad inputs; this counts the tables above."""
    n = (len(VEHICLE_CASES) + 6 * 3 + len(CERT_CASES) + 7 * 2 + 3 + 1 + len(OUTPUT_SLOTS) * len(BAD_FILES) + 7
         + 7 + 5 + 1 + 1 + len(OPTION_CASES) + 1)
    assert n >= 150, n
