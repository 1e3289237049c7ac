"""The rows of ``verify``'s cascade re-check (:func:`check_cascade_section`), one edit at a time.

tests/test_robust_cascade.py shows that stated numbers edited past their tolerance are refused.  Here each row
is shown to be the one that answers for its part of the section: the true section gives exactly the rows
:data:`ROWS`, each passing with a one-line detail; every edit below fails exactly the rows named beside it
(no other row moves), an unreadable part is a failed row and never an exception, and a part that the later rows
need stops the re-check there.
"""

from __future__ import annotations

import copy
from typing import Any, Callable

import pytest

from nniquad.analysis import robust_cascade as RC
from nniquad.config import CASCADE_GRID_MAX_POINTS_PER_AXIS
from tests.test_robust_cascade import BOX, GAINS, INNER, RATE, TILT, V

#: The rows of a true section, in the order ``verify`` prints them (cheap rows first).
ROWS = ["section keys", "controller variant", "Monte Carlo default box", "stated method texts and subsystem states",
        "covers_monte_carlo_default", "tilt limit and u0", "relevant coordinates", "nominal matrices rebuilt",
        "subsystems decoupled", "Lyapunov LMI [x]", "Lyapunov LMI [y]", "Lyapunov LMI [altitude]",
        "Lyapunov LMI [yaw]", "rho and decay rate", "grid check", "region of attraction", "start certified",
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
    "grid points per axis left out": (_drop("grid", "points_per_axis"), {"grid check", "region of attraction"}),
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
    fast = _rows(sec, fail_fast=True)
    assert fast == rows[:len(fast)] and not fast[-1][1] and fast[-1][0] == next(n for n in ROWS if n in expected)


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


def test_numbers_moved_within_their_tolerances_still_pass(section):
    """The other side of every tolerance above: moved by half of it, nothing fails (an exact comparison, or a
    tighter one, would refuse a true certificate checked on another machine)."""
    sec = copy.deepcopy(section)
    _within_tolerance(sec)
    rows = _rows(sec)
    assert [n for n, ok, _ in rows if not ok] == [] and [n for n, _, _ in rows] == ROWS


def test_the_largest_grid_allowed_is_allowed(section, monkeypatch):
    """The grid-size limit is inclusive: with the limit lowered to this section's 2 points, it still passes."""
    import nniquad.analysis.robust.check as check

    monkeypatch.setattr(check, "CASCADE_GRID_MAX_POINTS_PER_AXIS", section["grid"]["points_per_axis"])
    assert all(ok for _, ok, _ in _rows(section))
    monkeypatch.setattr(check, "CASCADE_GRID_MAX_POINTS_PER_AXIS", section["grid"]["points_per_axis"] - 1)
    assert [n for n, ok, _ in _rows(section) if not ok] == ["rate and box"]
