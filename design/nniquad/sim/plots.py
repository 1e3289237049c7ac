"""Matplotlib figures of simulated runs: what :meth:`nniquad.sim.results.SimulationResult.plot` draws.

Every function takes results that were already computed (a
:class:`~nniquad.sim.results.Trajectory` or a :class:`~nniquad.sim.results.SimulationResult`, read by
attribute), draws them, and writes
a PNG atomically (a crash never leaves half a file).  Figures are built with
:class:`matplotlib.figure.Figure` directly (no pyplot state), so no display is
needed and a notebook's backend is left alone.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from nniquad.config import BAND_FRACTION
from nniquad.io import atomic_write_with
from nniquad.laws.base import gains_text

__all__ = ["trajectory_plot", "paper_figure", "runs_plot", "MODEL_STYLE"]

#: Line style per model, shared by every figure.
MODEL_STYLE: dict[str, dict[str, object]] = {
    "linear": {"color": "tab:blue", "ls": "-", "lw": 1.2, "label": "linear (reduced loop, no limit)"},
    "reduced": {"color": "tab:orange", "ls": "--", "lw": 1.2, "label": "reduced (tilt limit)"},
    "full": {"color": "tab:red", "ls": "-", "lw": 1.0, "label": "full vehicle (inner loops, rotor limits)"},
}


def _figure(**kw):
    """A figure that does not touch pyplot's global state (works headless, in notebooks and threads)."""
    from matplotlib.figure import Figure

    return Figure(**kw)


def _save(fig, path: str | os.PathLike[str]) -> Path:
    return atomic_write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=130))


def _band(traj: "Trajectory") -> float:
    return BAND_FRACTION * float(np.hypot(*traj.xy[0]))


def trajectory_plot(traj: "Trajectory", path: str | os.PathLike[str]) -> Path:
    """Plot one run: position, distance (log) with the 2 % band, tilt, and for ``full`` rotors and altitude.

    Parameters
    ----------
    traj
        A :class:`nniquad.sim.results.Trajectory`.
    path
        PNG file to write.
    """
    full = traj.model == "full"
    n = 4 if full else 3
    fig = _figure(figsize=(9, 2.3 * n + 0.6))
    axes = fig.subplots(n, 1, sharex=True)
    g = traj.gains
    fig.suptitle(f"{traj.model} model, {gains_text(g, sep=', ', greek=True)}")
    ax = axes[0]
    ax.plot(traj.t, traj.xy[:, 0], label="x (north)")
    ax.plot(traj.t, traj.xy[:, 1], label="y (east)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("position [m]")
    ax.legend(loc="upper right")
    ax = axes[1]
    d = np.hypot(traj.xy[:, 0], traj.xy[:, 1])
    ax.semilogy(traj.t, np.maximum(d, 1e-6), color="k", label="‖ξ_h‖")
    ax.axhline(_band(traj), color="tab:green", ls=":", label="2 % band")
    m = traj.metrics()
    if m.settling_s is not None:
        ax.axvline(m.settling_s, color="tab:green", lw=0.8, label=f"settled {m.settling_s:.1f} s")
    ax.set_ylabel("distance [m]")
    ax.legend(loc="upper right")
    ax = axes[2]
    ax.plot(traj.t, traj.cmd_tilt_deg, label="commanded tilt", color="tab:purple")
    ax.plot(traj.t, traj.tilt_deg, label="actual tilt", color="k", lw=0.8)
    if traj.model != "linear":
        ax.axhline(traj.options.tilt_limit_deg, color="tab:red", ls=":", label="tilt limit")
    ax.set_ylabel("tilt [deg]")
    ax.legend(loc="upper right")
    if full:
        ax = axes[3]
        w = traj.rotor_speeds
        for i in range(4):
            ax.plot(traj.t, w[:, i], lw=0.7, label=f"ω{i + 1}")
        ax.axhline(traj.vehicle.omega_max, color="tab:red", ls=":", label="ω_max")
        ax.set_ylabel("rotor speed [rad/s]")
        ax2 = ax.twinx()
        ax2.plot(traj.t, -traj.z_ned * 1e3, color="k", lw=0.8, label="height error")
        ax2.set_ylabel("height error [mm]")
        ax.legend(loc="upper right", ncol=5, fontsize=7)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    return _save(fig, path)


def paper_figure(
    results: Mapping[str, "Trajectory"] | Sequence["Trajectory"],
    path: str | os.PathLike[str],
    *,
    zoom_s: float = 10.0,
    title: str | None = None,
) -> Path:
    """The figure the paper announces but does not show: x(t) and y(t) on each model.

    Left: x(t) and y(t) over the whole horizon and the distance ‖ξ_h(t)‖ on a
    log scale with the 2 % band (so a slow decay and a growing oscillation are
    both readable).  Right: the first ``zoom_s`` seconds.  Runs whose positions
    would flatten the others (the full vehicle's growing oscillation at the
    paper's gains) get their own right-hand axis in the position panels.

    Parameters
    ----------
    results
        Trajectories keyed by model (or a sequence; keyed by their ``model``),
        e.g. from :func:`nniquad.sim.paper_figure_runs`.
    path
        PNG file to write.
    zoom_s
        Length of the zoomed window [s].
    title
        Figure title; default names the gains.
    """
    runs = dict(results) if isinstance(results, Mapping) else {tr.model: tr for tr in results}
    if not runs:
        raise ValueError("paper_figure needs at least one trajectory")
    first = next(iter(runs.values()))
    g = first.gains
    fig = _figure(figsize=(12, 8.5))
    gs = fig.add_gridspec(3, 3)
    ax_x = fig.add_subplot(gs[0, :2])
    ax_y = fig.add_subplot(gs[1, :2], sharex=ax_x)
    ax_d = fig.add_subplot(gs[2, :2], sharex=ax_x)
    zx = fig.add_subplot(gs[0, 2])
    zy = fig.add_subplot(gs[1, 2], sharex=zx)
    zt = fig.add_subplot(gs[2, 2], sharex=zx)
    bounded = [tr for m, tr in runs.items() if m != "full"] or list(runs.values())
    lim = 1.15 * max(float(np.nanmax(np.abs(tr.xy))) for tr in bounded)
    twin_x = twin_y = None
    for model, tr in runs.items():
        style = dict(MODEL_STYLE.get(model, {"label": model}))
        m = tr.metrics()
        s = "not settled" if m.settling_s is None else f"settles {m.settling_s:.0f} s"
        label = f"{style.pop('label')}: {s}"
        peak = float(np.nanmax(np.abs(tr.xy)))
        ax1, ax2 = ax_x, ax_y
        if peak > lim:  # would flatten the other runs: its own (right) axis
            twin_x, twin_y = ax_x.twinx(), ax_y.twinx()
            ax1, ax2 = twin_x, twin_y
            label += " (right axis)"
            for ax in (twin_x, twin_y):
                ax.set_ylim(-1.05 * peak, 1.05 * peak)
                ax.tick_params(axis="y", colors=style.get("color", "k"))
        ax1.plot(tr.t, tr.xy[:, 0], label=label, **style)
        ax2.plot(tr.t, tr.xy[:, 1], **style)
        ax_d.semilogy(tr.t, np.maximum(np.hypot(tr.xy[:, 0], tr.xy[:, 1]), 1e-9), **style)
        w = tr.t <= zoom_s
        zx.plot(tr.t[w], tr.xy[w, 0], **style)
        zy.plot(tr.t[w], tr.xy[w, 1], **style)
        zt.plot(tr.t[w], tr.tilt_deg[w], **style)
    ax_x.set_ylim(-lim, lim)
    ax_y.set_ylim(-lim, lim)
    ax_d.axhline(_band(first), color="tab:green", ls=":", lw=1, label="2 % band")
    ax_x.set_ylabel("x (north) [m]")
    ax_y.set_ylabel("y (east) [m]")
    ax_d.set_ylabel("‖ξ_h‖ [m]")
    ax_d.set_xlabel("time [s]")
    ax_d.legend(loc="lower left", fontsize=8)
    zx.set_title(f"first {zoom_s:g} s")
    zx.set_ylabel("x [m]")
    zy.set_ylabel("y [m]")
    zt.set_ylabel("tilt [deg]")
    zt.set_xlabel("time [s]")
    handles, labels = ax_x.get_legend_handles_labels()
    if twin_x is not None:
        h2, l2 = twin_x.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
        twin_x.set_ylabel("x, full [m]")
        twin_y.set_ylabel("y, full [m]")
    ax_x.legend(handles, labels, loc="upper left", fontsize=8)
    ax_d.set_ylim(bottom=_band(first) / 20)
    for ax in (ax_x, ax_y, zx, zy):
        ax.axhline(0, color="k", lw=0.4)
    xi0 = first.xy[0]
    fig.suptitle(title or (f"Horizontal position from ξ_h(0) = ({xi0[0]:g}, {xi0[1]:g}) m, "
                           + gains_text(g, sep=", ", greek=True).replace("=", " = ")))
    fig.tight_layout()
    return _save(fig, path)


def runs_plot(result: "SimulationResult", path: str | os.PathLike[str] | None = None, *,
              labels: Sequence[str] | None = None, title: str | None = None):
    """Every run of a :class:`nniquad.sim.results.SimulationResult`: distance (log, with the 2 % band) and tilt.

    Parameters
    ----------
    result
        The runs (``SimulationResult.plot`` calls this).
    path
        PNG file to write; ``None`` only returns the figure.
    labels
        One legend label per run; default the gains.
    title
        Figure title; default the model and the number of runs.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = len(result)
    if labels is not None and len(labels) != n:
        raise ValueError(f"{len(labels)} labels for {n} runs")
    fig = _figure(figsize=(9, 6))
    ax_d, ax_t = fig.subplots(2, 1, sharex=True)
    dist, tilt = result.distance, result.tilt_deg
    for i in range(n):
        label = labels[i] if labels is not None else ", ".join(f"{k}={v:.4g}" for k, v in result.gains[i].as_dict().items())
        ax_d.semilogy(result.t, np.maximum(dist[i], 1e-9), lw=1.0, label=label)
        ax_t.plot(result.t, tilt[i], lw=1.0)
    ax_d.axhline(BAND_FRACTION * float(dist[0, 0]), color="tab:green", ls=":", lw=1, label="2 % band")
    ax_d.set_ylabel("‖ξ_h‖ [m]")
    ax_t.set_ylabel("tilt [deg]")
    ax_t.set_xlabel("time [s]")
    ax_d.legend(loc="upper right", fontsize=7)
    fig.suptitle(title or f"{result.model} model, {n} run{'s' if n != 1 else ''} ({result.controller})")
    fig.tight_layout()
    if path is not None:
        _save(fig, path)
    return fig
