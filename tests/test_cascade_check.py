"""The rows of ``verify``'s cascade re-check (:func:`check_cascade_section`), one edit at a time.

tests/test_robust_cascade.py shows that stated numbers edited past their tolerance are refused.  Here each row
is shown to be the one that answers for its part of the section: the true section gives exactly the rows
:data:`ROWS`, each passing with a one-line detail; every edit below fails exactly the rows named beside it
(no other row moves), an unreadable part is a failed row and never an exception, and a part that the later rows
need stops the re-check there.
"""

from __future__ import annotations

import copy
import math
from typing import Any, Callable

import numpy as np
import pytest

from nniquad.analysis.cascade import box_certificate as RC
from nniquad.config import CASCADE_GRID_MAX_POINTS_PER_AXIS
from tests.test_robust_cascade import BOX, GAINS, INNER, RATE, TILT, V

#: The rows of a true section, in the order ``verify`` prints them (cheap rows first).
ROWS = ["section keys", "controller variant", "Monte Carlo default box", "stated method texts and subsystem states",
        "covers_monte_carlo_default", "tilt limit and u0", "relevant coordinates", "nominal matrices rebuilt",
        "subsystems decoupled", "Lyapunov LMI [x]", "Lyapunov LMI [y]", "Lyapunov LMI [altitude]",
        "Lyapunov LMI [yaw]", "rho and decay rate", "grid check", "box cells", "region of attraction", "start certified",
        "margins at the stated worst vertices"]


@pytest.fixture(scope="module")
def section(shared_json):
    # the section of tests/test_robust_cascade.py, built once per session
    return shared_json("robust-cascade-section", lambda: RC.cascade_section(
        V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=2))


def _rows(sec: Any, **kw) -> list[tuple[str, bool, str]]:
    return RC.check_cascade_section(sec, V, GAINS, INNER, tilt_limit_deg=TILT, **kw)


def test_a_true_section_gives_every_row_passing_with_a_detail(section):
    rows = _rows(section)
    assert [name for name, _, _ in rows] == ROWS
    assert all(ok is True for _, ok, _ in rows)
    assert all(isinstance(d, str) and d.strip() and "\n" not in d for _, _, d in rows)
    details = dict((n, d) for n, _, d in rows)
    assert details["section keys"] == "all present"
    assert details["grid check"].startswith(f"{section['grid']['size']} points")
    assert details["margins at the stated worst vertices"].endswith("vertices recomputed")
    # the rows whose detail is fixed, or is the stated value itself
    from nniquad.analysis.cascade.box import ParameterBox
    from nniquad.analysis.cascade.family import SUBSYSTEMS

    assert details["Monte Carlo default box"] == str(ParameterBox.monte_carlo_default().to_json())
    assert details["stated method texts and subsystem states"] == "form, coverage, notes, states"
    assert details["nominal matrices rebuilt"] == "A_d, Phi, Gamma_d, A_kd, B_kd, C_k, D_k vs the design"
    assert details["relevant coordinates"] == str({k: section["lyapunov"]["subsystems"][k]["dims"] for k in SUBSYSTEMS})
    assert details["subsystems decoupled"].endswith(f"(stated {section['lyapunov']['coupling']})")
    from nniquad.config import XI0_M

    reach = section["region_of_attraction"]["max_displacement_m"]
    assert details["region of attraction"].startswith(f"lure: stated reach {reach} m; ")
    assert details["start certified"] == (f"start {math.hypot(*XI0_M):.6g} m, reach {reach} m: stated "
                                          f"{section['start_certified']}")


def _set(path: tuple, value: Any) -> Callable[[dict], None]:
    def edit(sec: dict) -> None:
        node = sec
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = value
    return edit


def _scale(path: tuple, factor: float) -> Callable[[dict], None]:
    def edit(sec: dict) -> None:
        node = sec
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = node[path[-1]] * factor
    return edit


def _drop(*path: str) -> Callable[[dict], None]:
    def edit(sec: dict) -> None:
        node = sec
        for p in path[:-1]:
            node = node[p]
        del node[path[-1]]
    return edit


def _moved_worst_point(sec: dict) -> None:
    """The grid's stated worst point moved to the box's centre (a grid point only for an odd grid: here none)."""
    sec["grid"]["worst_point"] = {k: 1.0 for k in sec["grid"]["worst_point"]}


def _worst_point_off_a_vertex(sec: dict) -> None:
    w = sec["margins"]["worst"]["horizontal"]["pm_deg_point"]
    w["mass"] = 1.0  # the mass is a coordinate of the horizontal blocks: the worst margin sits at a vertex


#: (edit, the rows it fails).  Every other row must still pass.
ONE_ROW = {
    "controller continuous": (_set(("controller",), "continuous"), {"controller variant"}),
    "attitude loop discrete": (_set(("attitude_loop",), "discrete"), {"controller variant"}),
    "model text": (_set(("model",), "another model"), {"controller variant"}),
    "Monte Carlo box edited": (_set(("monte_carlo_default_box", "mass_factor"), [0.7, 1.2]),
                               {"Monte Carlo default box"}),
    "form text": (_set(("lyapunov", "form"), "another form"), {"stated method texts and subsystem states"}),
    "coverage text": (_set(("lyapunov", "coverage"), "everything"), {"stated method texts and subsystem states"}),
    "region note": (_set(("region_of_attraction", "note"), "a note"), {"stated method texts and subsystem states"}),
    "margin points text": (_set(("margins", "points"), "all"), {"stated method texts and subsystem states"}),
    "margin model text": (_set(("margins", "model"), "reduced"), {"stated method texts and subsystem states"}),
    "x states renamed": (lambda s: s["lyapunov"]["subsystems"]["x"]["states"].reverse(),
                         {"stated method texts and subsystem states"}),
    "covers flipped": (lambda s: s.update(covers_monte_carlo_default=not s["covers_monte_carlo_default"]),
                       {"covers_monte_carlo_default"}),
    "tilt limit stated 31": (_set(("region_of_attraction", "tilt_limit_deg"), 31.0), {"tilt limit and u0"}),
    "u0 edited": (_scale(("region_of_attraction", "u0_m_s2"), 1.001), {"tilt limit and u0"}),
    "state names": (lambda s: s["matrices"]["state_names"].reverse(), {"nominal matrices rebuilt"}),
    "A_kd edited": (lambda s: s["matrices"]["A_kd"][0].__setitem__(0, s["matrices"]["A_kd"][0][0] + 1e-3),
                    {"nominal matrices rebuilt"}),
    "B_kd edited": (lambda s: s["matrices"]["B_kd"][0].__setitem__(0, s["matrices"]["B_kd"][0][0] * 1.001 + 1e-6),
                    {"nominal matrices rebuilt"}),
    "C_k edited": (lambda s: s["matrices"]["C_k"][0].__setitem__(0, s["matrices"]["C_k"][0][0] * 1.001 + 1e-6),
                   {"nominal matrices rebuilt"}),
    "D_k edited": (lambda s: s["matrices"]["D_k"][0].__setitem__(0, s["matrices"]["D_k"][0][0] * 1.001 + 1e-6),
                   {"nominal matrices rebuilt"}),
    "Phi edited": (lambda s: s["matrices"]["Phi"][0].__setitem__(0, s["matrices"]["Phi"][0][0] * 1.001),
                   {"nominal matrices rebuilt"}),
    "Gamma_d edited": (lambda s: s["matrices"]["Gamma_d"][-1].__setitem__(0, s["matrices"]["Gamma_d"][-1][0] + 1e-3),
                       {"nominal matrices rebuilt"}),
    "a matrix entry that is text": (lambda s: s["matrices"]["A_d"][0].__setitem__(0, "one"),
                                    {"nominal matrices rebuilt"}),
    "a matrix row too short": (lambda s: s["matrices"]["C_k"][0].pop(), {"nominal matrices rebuilt"}),
    "state names left out": (_drop("matrices", "state_names"), {"nominal matrices rebuilt"}),
    # the coupling is a finite-difference residual at rounding level (2.5e-9 here), compared within an absolute
    # 1e-6 (relative 1e-6 of max(|value|, 1)): another machine's arithmetic moves it by more than 1 %
    "coupling stated 2e-6 larger": (lambda s: s["lyapunov"].update(coupling=s["lyapunov"]["coupling"] + 2e-6),
                                    {"subsystems decoupled"}),
    "x lmi points": (lambda s: s["lyapunov"]["subsystems"]["x"].update(lmi_points=80), {"Lyapunov LMI [x]"}),
    "x decay rate": (_scale(("lyapunov", "subsystems", "x", "decay_rate_1_s"), 1.001), {"Lyapunov LMI [x]"}),
    # the scaled P's smallest eigenvalue within an absolute 1e-9 (SCALED_EIG_ATOL): 1e-4 of 5e-5 is 5e-9
    "x min eig": (_scale(("lyapunov", "subsystems", "x", "min_eig_scaled"), 1 + 1e-4), {"Lyapunov LMI [x]"}),
    "x rounding bound as text": (lambda s: s["lyapunov"]["subsystems"]["x"].update(
        rho_rounding_bound=str(s["lyapunov"]["subsystems"]["x"]["rho_rounding_bound"])), {"Lyapunov LMI [x]"}),
    "C_k without its last row": (lambda s: s["matrices"]["C_k"].pop(), {"nominal matrices rebuilt"}),
    "A_d entry infinite": (lambda s: s["matrices"]["A_d"][0].__setitem__(0, float("inf")),
                           {"nominal matrices rebuilt"}),
    # not the largest rho, nor the slowest decay: "rho and decay rate" is unchanged
    "altitude rho": (_scale(("lyapunov", "subsystems", "altitude", "rho"), 0.999), {"Lyapunov LMI [altitude]"}),
    "x rho": (_scale(("lyapunov", "subsystems", "x", "rho"), 0.999), {"Lyapunov LMI [x]", "rho and decay rate"}),
    "yaw spectral radius": (_scale(("lyapunov", "subsystems", "yaw", "spectral_radius"), 1 + 1e-6),
                            {"Lyapunov LMI [yaw]"}),
    "period": (_scale(("lyapunov", "period_s"), 1.001), {"rho and decay rate"}),
    "section decay rate": (_scale(("decay_rate_1_s",), 0.999), {"rho and decay rate"}),
    "grid size": (lambda s: s["grid"].update(size=s["grid"]["size"] + 1), {"grid check"}),
    # without it, the default grid (4 per coordinate) is rebuilt: not the stated 2-point grid, on which the
    # linear-zone reach was stated too
    "grid points per axis left out": (_drop("grid", "points_per_axis"), {"grid check", "box cells",
                                                                         "region of attraction"}),
    "grid ok false": (_set(("grid", "ok"), False), {"grid check"}),
    # stated bounds within a relative 1e-3 (BOUND_RTOL), the margin over the bound within 1 + 1e-3 of it
    "grid rounding bound": (_scale(("grid", "rounding_bound"), 1.01), {"grid check"}),
    "grid margin over bound": (_scale(("grid", "margin_over_bound"), 1.01), {"grid check"}),
    "x rounding bound": (_scale(("lyapunov", "subsystems", "x", "rho_rounding_bound"), 1.01), {"Lyapunov LMI [x]"}),
    "yaw eigenvalue bound": (_scale(("lyapunov", "subsystems", "yaw", "min_eig_bound"), 0.99),
                             {"Lyapunov LMI [yaw]"}),
    "grid worst margin": (_scale(("grid", "worst_margin"), 1.001), {"grid check"}),
    "grid worst spectral radius": (_scale(("grid", "worst_spectral_radius"), 1 + 1e-6), {"grid check"}),
    "grid worst point not a grid point": (_moved_worst_point, {"grid check"}),
    "grid worst rho is text": (_set(("grid", "worst_rho"), "0.99"), {"grid check"}),
    "grid worst rho is true": (_set(("grid", "worst_rho"), True), {"grid check"}),
    "grid worst point unreadable": (_set(("grid", "worst_point"), None), {"grid check"}),
    "method unknown": (_set(("region_of_attraction", "method"), "ellipsoid"), {"region of attraction"}),
    "linear zone reach at the LMI points": (_scale(("region_of_attraction", "linear_zone_reach_lmi_points_m"), 1.001),
                                            {"region of attraction"}),
    "linear zone reach on the grid": (_scale(("region_of_attraction", "linear_zone_reach_grid_m"), 0.999),
                                      {"region of attraction"}),
    "reach stated smaller": (_scale(("region_of_attraction", "max_displacement_m"), 0.999), {"region of attraction"}),
    "reach stated as text": (lambda s: s["region_of_attraction"].update(
        max_displacement_m=str(s["region_of_attraction"]["max_displacement_m"])), {"region of attraction"}),
    "x P off its diagonal": (lambda s: [row.__setitem__(j, row[j] + 1e-4 * abs(s["lyapunov"]["subsystems"]["x"]["P"][0][0][0]))
                                       for j, row in ((1, s["lyapunov"]["subsystems"]["x"]["P"][0][0]),
                                                      (0, s["lyapunov"]["subsystems"]["x"]["P"][0][1]))],
                             {"Lyapunov LMI [x]", "grid check", "box cells"}),
    # inside the Lur'e block: its recomputation is cached by the block's own fields too (test below)
    "Lur'e level": (_scale(("region_of_attraction", "lure", "level"), 1.01), {"region of attraction"}),
    "Lur'e multiplier": (lambda s: s["region_of_attraction"]["lure"]["mu"].__setitem__(
        0, s["region_of_attraction"]["lure"]["mu"][0] * 1.01), {"region of attraction"}),
    "start certified flipped": (lambda s: s.update(start_certified=not s["start_certified"]), {"start certified"}),
    "a worst margin stated 1 % off": (_scale(("margins", "worst", "horizontal", "gm_db"), 1.01),
                                      {"margins at the stated worst vertices"}),
    "a worst margin stated unstable": (_set(("margins", "worst", "attitude", "stable"), False),
                                       {"margins at the stated worst vertices"}),
    "a worst margin point off a vertex": (_worst_point_off_a_vertex, {"margins at the stated worst vertices"}),
    "a worst margin unreadable": (_drop("margins", "worst", "attitude", "pm_deg_point"),
                                  {"margins at the stated worst vertices"}),
}


@pytest.mark.parametrize("name", list(ONE_ROW))
def test_an_edit_fails_exactly_its_rows(section, name):
    edit, expected = ONE_ROW[name]
    sec = copy.deepcopy(section)
    edit(sec)
    rows = _rows(sec)
    assert [n for n, _, _ in rows] == ROWS, name
    assert {n for n, ok, _ in rows if not ok} == expected, name
    assert all(isinstance(d, str) and d.strip() and "\n" not in d for _, _, d in rows), name
    fast = _rows(sec, fail_fast=True)
    assert fast == rows[:len(fast)] and not fast[-1][1] and fast[-1][0] == next(n for n in ROWS if n in expected)
    # verify's cache (grid check, region, margins by their exact inputs), holding the true section's results,
    # gives the same rows: none of them is handed back for an input the edit changed
    from nniquad.certificates.check_record import memo

    _rows(section, cache=memo)
    assert _rows(sec, cache=memo) == rows, name
    assert _rows(sec, fail_fast=True, cache=memo) == fast, name


#: (edit, the rows it fails, the last row before the re-check stops, words the first failed row's detail holds).
#: The later rows need what the edit removed.
GRID_SIZE = "grid.points_per_axis must be an integer from 2 to"
STOPS = {
    "a key missing": (_drop("grid"), ["section keys"], "section keys", "missing ['grid']"),
    "a section that is a list": (lambda s: None, ["section keys"], "section keys", "missing ['rate_hz'"),
    "rate is text": (_set(("rate_hz",), "fast"), ["rate and box"], "rate and box", "fast"),
    "rate below zero": (_set(("rate_hz",), -100.0), ["rate and box"], "rate and box", "rate"),
    "box upside down": (_set(("box", "mass_factor"), [1.2, 0.8]), ["rate and box"], "rate and box", "mass"),
    "grid of one point per axis": (_set(("grid", "points_per_axis"), 1), ["rate and box"], "rate and box",
                                   f"{GRID_SIZE} {CASCADE_GRID_MAX_POINTS_PER_AXIS}, got 1"),
    "grid larger than any certify writes": (_set(("grid", "points_per_axis"), CASCADE_GRID_MAX_POINTS_PER_AXIS + 1),
                                            ["rate and box"], "rate and box", GRID_SIZE),
    "grid size as text": (_set(("grid", "points_per_axis"), "2"), ["rate and box"], "rate and box", GRID_SIZE),
    "grid size as a boolean": (_set(("grid", "points_per_axis"), True), ["rate and box"], "rate and box",
                               "got True"),
    "grid size as a float": (_set(("grid", "points_per_axis"), 2.0), ["rate and box"], "rate and box", "got 2.0"),
    "grid not a mapping": (_set(("grid",), [2]), ["rate and box"], "rate and box", "get"),
    "subsystem dims unknown": (_set(("lyapunov", "subsystems", "yaw", "dims"), ["wind"]), ["lyapunov block"],
                               "lyapunov block", "unreadable"),
    "subsystem rho text": (_set(("lyapunov", "subsystems", "x", "rho"), "small"), ["lyapunov block"],
                           "lyapunov block", "small"),
    "a subsystem missing": (_drop("lyapunov", "subsystems", "altitude"),
                            ["stated method texts and subsystem states", "lyapunov block"], "lyapunov block",
                            "form, coverage, notes, states"),
    "x P with an entry that is text": (lambda s: s["lyapunov"]["subsystems"]["x"]["P"][0][0].__setitem__(0, "one"),
                                       ["lyapunov block"], "lyapunov block", "unreadable"),
    # every block is still re-checked, then the re-check stops: the grid needs all four
    "x P of another shape": (lambda s: s["lyapunov"]["subsystems"]["x"]["P"].pop(), ["Lyapunov LMI [x]"],
                             "Lyapunov LMI [yaw]", "bad P shape"),
}


@pytest.mark.parametrize("name", list(STOPS))
def test_an_unreadable_part_is_a_failed_row_and_stops_the_recheck(section, name):
    edit, failed, last, needle = STOPS[name]
    sec = copy.deepcopy(section)
    edit(sec)
    if name == "a section that is a list":
        sec = list(sec)
    rows = _rows(sec)
    assert rows[-1][0] == last and len(rows) < len(ROWS), (name, rows[-1])
    assert [n for n, ok, _ in rows if not ok] == failed, (name, rows)
    assert all(d.strip() for n, ok, d in rows if not ok)
    assert needle in next(d for n, ok, d in rows if not ok), (name, rows)
    if name == "x P of another shape":  # a fixed text: the whole detail
        assert rows[[n for n, _, _ in rows].index("Lyapunov LMI [x]")][2] == needle
    fast = _rows(sec, fail_fast=True)
    assert fast == rows[:[n for n, _, _ in rows].index(failed[0]) + 1]


def test_the_margin_points_stated_infinite_are_read_as_infinite(section):
    """A gain margin without a lower crossing is stated as the text ``-inf`` (JSON has no infinity): it is read as
    the number, and the same text with a sign changed is refused."""
    stated = [w["gm_lower_db"] for w in section["margins"]["worst"].values()]
    assert "-inf" in stated
    sec = copy.deepcopy(section)
    for w in sec["margins"]["worst"].values():
        if w["gm_lower_db"] == "-inf":
            w["gm_lower_db"] = "inf"
    assert {n for n, ok, _ in _rows(sec) if not ok} == {"margins at the stated worst vertices"}


def _within_tolerance(sec: dict) -> None:
    """Every stated number moved by far less than its tolerance, as another machine's arithmetic would move it."""
    m = sec["matrices"]
    for key in ("A_d", "Phi", "Gamma_d", "A_kd", "B_kd", "C_k", "D_k"):  # within 1e-9 of max(|entry|, 1)
        m[key] = [[v * (1 + 0.5e-9) + 1e-15 for v in row] for row in m[key]]
    for block in sec["lyapunov"]["subsystems"].values():
        block["min_eig_scaled"] += 0.5e-9  # SCALED_EIG_ATOL is 1e-9
        block["rho_rounding_bound"] *= 1 + 0.5e-3  # BOUND_RTOL is 1e-3
        block["min_eig_bound"] *= 1 - 0.5e-3
    g = sec["grid"]
    g["rounding_bound"] *= 1 + 0.5e-3
    g["margin_over_bound"] += 0.9  # within 1 + 1e-3 of itself
    sec["lyapunov"]["coupling"] += 0.5e-6  # an absolute 1e-6
    for w in sec["margins"]["worst"].values():  # the margins within 1e-6 of max(|value|, 1)
        for key in ("gm_db", "gm_lower_db", "pm_deg"):
            if isinstance(w[key], float):
                w[key] *= 1 + 0.5e-6


def test_numbers_moved_within_their_tolerances_still_pass(section):
    """The other side of every tolerance above: moved by half of it, nothing fails (an exact comparison, or a
    tighter one, would refuse a true certificate checked on another machine)."""
    sec = copy.deepcopy(section)
    _within_tolerance(sec)
    rows = _rows(sec)
    assert [n for n, ok, _ in rows if not ok] == [] and [n for n, _, _ in rows] == ROWS


def test_the_largest_grid_allowed_is_allowed(section, monkeypatch):
    """The grid-size limit is inclusive: with the limit lowered to this section's 2 points, it still passes."""
    import nniquad.analysis.cascade.lyapunov as rule  # the one grid-size rule, shared with certify

    monkeypatch.setattr(rule, "CASCADE_GRID_MAX_POINTS_PER_AXIS", section["grid"]["points_per_axis"])
    assert all(ok for _, ok, _ in _rows(section))
    monkeypatch.setattr(rule, "CASCADE_GRID_MAX_POINTS_PER_AXIS", section["grid"]["points_per_axis"] - 1)
    assert [n for n, ok, _ in _rows(section) if not ok] == ["rate and box"]


# ----------------------------------------------------------------------------- the comparison helpers, by hand
# Each tolerance is inclusive (a value exactly at it passes, one twice as far fails): the numbers are dyadic or
# exact multiples, so the differences below are exact in binary and sit on the tolerance itself.

def test_close_by_hand():
    from nniquad.analysis.cascade.recheck import _close

    assert _close(1.5, 1.0, rtol=0.5) and not _close(1.5 + 2.0 ** -40, 1.0, rtol=0.5)  # |a - b| = rtol max(|b|, 1)
    assert _close(0.0, 0.0, rtol=0.0) and not _close(1e-290, 0.0, rtol=0.0)  # exact equality at rtol 0
    assert _close(1e-10, 0.0) and not _close(2e-9, 0.0)  # an absolute floor of rtol below |b| = 1
    assert _close(1e6 + 1e-4, 1e6) and not _close(1e6 + 1e-2, 1e6)  # relative above it
    assert _close([[1.0, 2.0]], [[1.0, 2.0]]) and not _close([1.0, 2.0], [1.0, 2.0, 3.0]) and _close([], [])
    # non-finite values are equal only to the same non-finite values (inf - inf is nan, and nan is never close)
    assert _close(np.inf, np.inf) and _close([-np.inf, 1.0], [-np.inf, 1.0]) and not _close(np.nan, np.nan)
    assert not _close(1.0, np.inf) and not _close(np.inf, 1.0) and not _close([np.inf, 1.0], [1.0, np.inf])
    # anything unreadable, on either side, is not close (and never an exception)
    for a, b in ((None, 1.0), ("x", 1.0), (1.0, "x"), ({"a": 1}, 1.0), (1.0, [1.0, "x"])):
        assert not _close(a, b), (a, b)


TOL = 2.0 ** -20  # a rounding bound above _same_worst's floor of 1e-9, exact in binary


def _grid_check(rho: list[float], spectral: list[float]):
    from nniquad.analysis.cascade.lyapunov import GridCheck

    pts = np.array([[1.0] * 6, [2.0] * 6])
    i, j = int(np.argmax(rho)), int(np.argmax(spectral))
    gc = GridCheck(size=2, points_per_axis=2, worst_rho=max(rho), worst_margin=1.0 - max(rho),
                   worst_point=tuple(pts[i]), worst_spectral_radius=max(spectral), worst_spectral_point=tuple(pts[j]),
                   rounding_bound=TOL, margin_over_bound=1e6, rho_all=np.array(rho), spectral_all=np.array(spectral))
    return gc, pts


def _stated(rho: float, rho_row: int, sr: float, sr_row: int, margin: float) -> dict:
    from nniquad.analysis.cascade.box import POINT_NAMES

    point = lambda row: dict(zip(POINT_NAMES, [float(row + 1)] * 6))  # noqa: E731
    return {"worst_rho": rho, "worst_point": point(rho_row), "worst_spectral_radius": sr,
            "worst_spectral_point": point(sr_row), "worst_margin": margin}


@pytest.mark.parametrize("k, ok", [(0, True), (1, True), (2, False)])
def test_same_worst_compares_values_within_the_rounding_bound(k, ok):
    """Every value that _same_worst compares, moved by k rounding bounds: up to one is the same worst."""
    from nniquad.analysis.cascade.recheck import _same_worst

    gc, pts = _grid_check([0.5, 0.25], [0.25, 0.5])
    d = k * TOL
    assert _same_worst(_stated(0.5 + d, 0, 0.5, 1, 0.5), gc, pts) is ok  # the stated worst contraction
    assert _same_worst(_stated(0.5, 0, 0.5 - d, 1, 0.5), gc, pts) is ok  # the stated worst spectral radius
    assert _same_worst(_stated(0.5, 0, 0.5, 1, 0.5 + d), gc, pts) is ok  # the stated worst margin
    # a stated point whose own value is k bounds below the worst (a tie to rounding when k <= 1)
    gc, pts = _grid_check([0.5, 0.5 - d], [0.5 - d, 0.5])
    assert _same_worst(_stated(0.5, 1, 0.5, 1, 0.5), gc, pts) is ok
    assert _same_worst(_stated(0.5, 0, 0.5, 0, 0.5), gc, pts) is ok


def test_same_worst_refuses_a_point_off_the_grid_and_a_value_that_is_no_number():
    from nniquad.analysis.cascade.recheck import _same_worst

    gc, pts = _grid_check([0.5, 0.25], [0.25, 0.5])
    assert _same_worst(_stated(0.5, 0, 0.5, 1, 0.5), gc, pts)
    assert not _same_worst(_stated(0.5, 2, 0.5, 1, 0.5), gc, pts)  # the point (3, ..., 3) is not a grid point
    for bad in ("0.5", True, float("nan"), None):
        assert not _same_worst(_stated(bad, 0, 0.5, 1, 0.5), gc, pts), bad
        assert not _same_worst(_stated(0.5, 0, 0.5, 1, bad), gc, pts), bad


def test_a_stated_margin_is_compared_on_its_own_scale():
    from nniquad.analysis.cascade.recheck import BOUND_RTOL, SCALED_EIG_ATOL, _stated_margin_ok

    assert BOUND_RTOL * 1000.0 == 1.0 and SCALED_EIG_ATOL == 1e-9  # the exact boundaries used below
    # the scaled smallest eigenvalue: absolutely, within 1e-9
    assert _stated_margin_ok("min_eig_scaled", 1e-9, 0.0) and not _stated_margin_ok("min_eig_scaled", 2e-9, 0.0)
    assert _stated_margin_ok("min_eig_scaled", 0.5, 0.5 + 1e-10)
    # a rounding bound: relatively, within 1e-3 of itself, with no absolute floor (a bound of 1e-14 stated as 0
    # or as 1e-10 is refused)
    for key in ("rho_rounding_bound", "min_eig_bound", "rounding_bound"):
        assert _stated_margin_ok(key, 1001.0, 1000.0) and _stated_margin_ok(key, 999.0, 1000.0), key
        assert not _stated_margin_ok(key, 1002.0, 1000.0) and not _stated_margin_ok(key, 998.0, 1000.0), key
        assert not _stated_margin_ok(key, 0.0, 1e-14) and not _stated_margin_ok(key, 1e-10, 1e-14), key
        assert _stated_margin_ok(key, 1e-14 * (1 + 1e-4), 1e-14), key
    for bad in ("1000.0", True, None, float("nan"), float("inf")):
        assert not _stated_margin_ok("rounding_bound", bad, 1000.0), bad
        assert not _stated_margin_ok("min_eig_scaled", bad, 0.5), bad


# ----------------------------------------------------------------------------- rows decided inside the re-check

def test_a_family_that_cannot_be_rebuilt_is_a_failed_row_that_stops_the_recheck(section, monkeypatch):
    import nniquad.analysis.cascade.recheck as check
    from nniquad.errors import CascadeError

    def refuse(*args, **kwargs):
        raise CascadeError("no family at these parameters")

    monkeypatch.setattr(check, "family_cached", refuse)
    rows = _rows(section)
    before = ROWS[:ROWS.index("tilt limit and u0") + 1]
    assert [n for n, _, _ in rows[:-1]] == before and all(ok for _, ok, _ in rows[:-1])
    assert rows[-1] == ("rebuild", False, "no family at these parameters")


def test_the_coupling_is_measured_on_the_nominal_loop_and_its_limit_is_inclusive(section, monkeypatch):
    import nniquad.analysis.cascade.recheck as check

    sizes: list[int] = []
    real = check.coupling
    monkeypatch.setattr(check, "coupling", lambda fam: sizes.append(len(fam)) or real(fam))
    assert all(ok for _, ok, _ in _rows(section)) and sizes == [1]
    # a coupling exactly at the limit is decoupled (the stated value the same number); one just above it is not
    at = 2.0 ** -30
    sec = copy.deepcopy(section)
    sec["lyapunov"]["coupling"] = at
    monkeypatch.setattr(check, "coupling", lambda fam: at)
    monkeypatch.setattr(check, "COUPLING_TOL", at)
    assert all(ok for _, ok, _ in _rows(sec))
    monkeypatch.setattr(check, "COUPLING_TOL", at / 2)
    assert [n for n, ok, _ in _rows(sec) if not ok] == ["subsystems decoupled"]


def _state_rho(sec: dict, rho: dict[str, float]) -> None:
    """Blocks' stated rho set to ``rho``, with every number stated from them (each block's decay rate, the
    section's rho and decay rate) set consistently: only the comparison with the recomputed contraction sees it."""
    subs, T = sec["lyapunov"]["subsystems"], sec["lyapunov"]["period_s"]
    for name, value in rho.items():
        subs[name]["rho"] = value
        subs[name]["decay_rate_1_s"] = -math.log(value) / T
    sec["lyapunov"]["rho"] = max(b["rho"] for b in subs.values())
    sec["decay_rate_1_s"] = min(b["decay_rate_1_s"] for b in subs.values())


def test_a_stated_rho_equals_the_contraction_within_its_rounding_bound(section, monkeypatch):
    """The tolerance of a stated rho is max(1e-9, the contraction's rounding bound), inclusive.

    At this section's bounds (about 1e-12), 4.8e-7 away is refused.  With the recomputed contraction and its bound
    replaced by dyadic numbers (0.5 and B = 9.5e-7 at every block), a stated rho k B / 2 away passes for k <= 2 and
    fails for k = 3: the differences are exact in binary.
    """
    import dataclasses

    import nniquad.analysis.cascade.recheck as check

    sec = copy.deepcopy(section)
    x = sec["lyapunov"]["subsystems"]["x"]["rho"]
    _state_rho(sec, {"x": x + 2.0 ** -21})
    assert [n for n, ok, _ in _rows(sec) if not ok] == ["Lyapunov LMI [x]"]
    B = 2.0 ** -20
    real = check.witness_margins
    monkeypatch.setattr(check, "witness_margins", lambda *a: dataclasses.replace(real(*a), rho=0.5, rho_bound=B))
    # the proofs at the stated rho are another row's concern (tests/test_verified.py, the box proof): here they pass
    from nniquad.analysis.verified.inequalities import ProofRow

    monkeypatch.setattr(check, "lyapunov_point_proofs", lambda *a: [ProofRow("stand-in", "proven", "verified-cholesky")])
    sec = copy.deepcopy(section)
    for block in sec["lyapunov"]["subsystems"].values():
        block["rho_rounding_bound"] = B
    for k, ok in ((0, True), (1, True), (2, True), (3, False)):
        _state_rho(sec, {name: 0.5 for name in sec["lyapunov"]["subsystems"]} | {"x": 0.5 + k * B / 2})
        rows = _rows(sec)
        assert [n for n, good, _ in rows if not good] == ([] if ok else ["Lyapunov LMI [x]"]), k
    yaw = dict((n, d) for n, _, d in rows)["Lyapunov LMI [yaw]"]
    assert f"contraction 0.5000000000 = rho 0.5000000000 < 1 by 0.5 (rounding bound {B:.2g});" in yaw


def test_a_stated_margin_over_its_bound_is_known_to_one_plus_a_share_of_itself(section, monkeypatch):
    """The grid's stated ``margin_over_bound`` within ``1 + 1e-3 x`` the recomputed one, inclusive: with the
    recomputed ratio replaced by 1000 (dyadic offsets below are exact), 1000 +- 2 passes and 1000 +- 2.5 fails."""
    import dataclasses

    import nniquad.analysis.cascade.recheck as check

    real = check.grid_check
    monkeypatch.setattr(check, "grid_check", lambda *a: dataclasses.replace(real(*a), margin_over_bound=1000.0))
    sec = copy.deepcopy(section)
    for stated, ok in ((1000.0, True), (1002.0, True), (998.0, True), (1002.5, False), (997.5, False),
                       ("1000", False), (True, False)):
        sec["grid"]["margin_over_bound"] = stated
        assert [n for n, good, _ in _rows(sec) if not good] == ([] if ok else ["grid check"]), stated


def test_a_linear_zone_region_states_the_linear_zone_reach_and_nothing_else(section):
    """Method ``linear_zone`` (the sni2 law's region): the reach is the smaller linear-zone reach, and a section
    that also states a Lur'e block, or another reach, is refused on that row alone."""
    from nniquad.config import XI0_M

    sec = copy.deepcopy(section)
    roa = sec["region_of_attraction"]
    reach = min(roa["linear_zone_reach_lmi_points_m"], roa["linear_zone_reach_grid_m"])
    roa["method"], roa["max_displacement_m"] = "linear_zone", reach
    sec["start_certified"] = bool(math.hypot(*XI0_M) <= reach)
    with_lure = copy.deepcopy(sec)
    del roa["lure"]
    assert [n for n, ok, _ in _rows(sec) if not ok] == []
    assert [n for n, ok, _ in _rows(with_lure) if not ok] == ["region of attraction"]
    roa["max_displacement_m"] = reach * 0.999
    assert [n for n, ok, _ in _rows(sec) if not ok] == ["region of attraction"]


def test_the_region_is_rechecked_at_each_horizontal_axis_own_lmi_points(section, monkeypatch):
    """The Lur'e block of an axis is re-checked on the family at that axis's LMI points (the subgrid of the box
    in the axis's coordinates), rebuilt here independently."""
    import nniquad.analysis.cascade.recheck as check
    from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox, grid_subset
    from nniquad.analysis.cascade.region import HORIZONTAL
    from nniquad.analysis.cascade.section import LMI_POINTS_PER_AXIS

    seen: dict = {}
    real = check.check_lure_block

    def spy(block, dims, box, lmi, grid, lyap):
        seen.update(lmi)
        return real(block, dims, box, lmi, grid, lyap)

    monkeypatch.setattr(check, "check_lure_block", spy)
    assert all(ok for _, ok, _ in _rows(section))
    box = ParameterBox.from_json(section["box"])
    assert set(seen) == set(HORIZONTAL)
    for name in HORIZONTAL:
        dims = tuple(POINT_NAMES.index(d) for d in section["lyapunov"]["subsystems"][name]["dims"])
        np.testing.assert_array_equal(seen[name].points, grid_subset(box, dims, LMI_POINTS_PER_AXIS))


@pytest.mark.parametrize("recomputed, stated, ok", [
    (2.0, 2.0, True),  # the recomputed reach itself
    (2.0, 2.0 * (1 - 2e-9), True),  # smaller by the allowed rounding share (the same product: exact)
    (2.0, 2.0 * (1 - 4e-9), False),  # smaller by more: not what was recomputed
    (2.0, float(np.nextafter(2.0, 3.0)), False),  # larger by one ulp: never stated beyond the recomputed reach
    (1.5, 1.5, True),
    (1.0, 1.0, False),  # a Lur'e reach no further than the linear zone's (1.0 here) is refused
])
def test_the_stated_lure_reach_is_the_recomputed_one_never_larger_and_past_the_linear_zone(section, monkeypatch,
                                                                                           recomputed, stated, ok):
    import nniquad.analysis.cascade.recheck as check
    from nniquad.config import XI0_M

    monkeypatch.setattr(check, "linear_zone_reach", lambda *a: 1.0)
    monkeypatch.setattr(check, "check_lure_block", lambda *a: (True, "the stub's region", recomputed))
    sec = copy.deepcopy(section)
    roa = sec["region_of_attraction"]
    roa["linear_zone_reach_lmi_points_m"] = roa["linear_zone_reach_grid_m"] = 1.0
    roa["max_displacement_m"] = stated
    sec["start_certified"] = bool(math.hypot(*XI0_M) <= stated)
    assert [n for n, good, _ in _rows(sec) if not good] == ([] if ok else ["region of attraction"])


def test_a_start_exactly_at_the_reach_is_certified(section):
    """The region is closed: a start at exactly the stated reach is inside it (and one an ulp further is not)."""
    reach = section["region_of_attraction"]["max_displacement_m"]
    sec = copy.deepcopy(section)
    sec["start_certified"] = True
    assert all(ok for _, ok, _ in _rows(sec, xi0_m=(0.0, reach)))
    assert [n for n, ok, _ in _rows(sec, xi0_m=(0.0, float(np.nextafter(reach, 10 * reach))))
            if not ok] == ["start certified"]


def test_an_unreadable_region_is_a_failed_row_with_a_detail(section):
    sec = copy.deepcopy(section)
    del sec["region_of_attraction"]["max_displacement_m"]
    rows = _rows(sec)
    assert all(isinstance(d, str) and d.strip() for _, _, d in rows)
    last = [(ok, d) for n, ok, d in rows if n == "region of attraction"][-1]
    assert last[0] is False and last[1].startswith("unreadable (")


def test_the_margins_are_recomputed_at_the_stated_rate(section, monkeypatch):
    import nniquad.analysis.cascade.recheck as recheck

    rates: list = []
    real = recheck.fast_cascade_margins

    def spy(*args, **kwargs):
        rates.append(args[1:] + tuple(kwargs.values()))
        return real(*args, **kwargs)

    monkeypatch.setattr(recheck, "fast_cascade_margins", spy)  # the name the re-check calls
    assert all(ok for _, ok, _ in _rows(section))
    assert rates and set(rates) == {(section["rate_hz"],)}
