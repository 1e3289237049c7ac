"""Results of simulations: many runs with named signals (:class:`SimulationResult`), one run (:class:`Trajectory`).

In the manner of python-control's ``TimeResponseData``: :func:`nniquad.sim.simulate`
returns one :class:`SimulationResult` holding every run it simulated, with the
time vector, the states and outputs as arrays with a leading run axis, named
signal accessors (``xy``, ``phi``, ``theta``, ``tilt_deg``, ``z_ned``,
:meth:`SimulationResult.state`, :meth:`SimulationResult.output`), the metrics
of every run (one definition, :mod:`nniquad.sim.metrics`) and ``plot()``
(drawn by :mod:`nniquad.sim.plots`).  ``result[i]`` is a
:class:`Trajectory`, the view of run ``i``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from nniquad.errors import SimulationError
from nniquad.io import atomic_write_with
from nniquad.laws.base import GainBlock
from nniquad.model.vehicle import Vehicle
from nniquad.sim.metrics import settling_time_batch, tilt_deg
from nniquad.sim.options import SimOptions
from nniquad.sim.params import SimParams
from nniquad.sim.plots import runs_plot
from nniquad.sim.tracking import TrackingMetrics, tracking_metrics
from nniquad.sim.verdicts import Metrics, altitude_lost_batch, compute_metrics, diverged_batch

__all__ = ["Trajectory", "SimulationResult"]


@dataclass
class Trajectory:
    """One simulated run, sampled every ``options.output_dt_s``.

    Attributes
    ----------
    model, options, gains, vehicle
        What was simulated (``vehicle`` is ``None`` when the run was given as
        parameters only).
    t : ndarray (N,)
        Sample times [s], starting at 0.
    state : ndarray (N, nx)
        States, columns :attr:`state_names`.
    outputs : ndarray (N, ny)
        Outputs, columns :attr:`output_names` (commanded acceleration after
        the limit [m/s²], commanded tilt [rad], rotor speeds [rad/s], ...).
    state_names, output_names
        Column names (:data:`nniquad.sim.params.STATE_NAMES`, ``OUTPUT_NAMES``).
    params
        The :class:`nniquad.sim.params.SimParams` of the run (``None`` if unknown).
    """

    model: str
    options: SimOptions
    gains: GainBlock
    vehicle: Vehicle | None
    t: np.ndarray
    state: np.ndarray
    outputs: np.ndarray
    state_names: tuple[str, ...] = field(default=())
    output_names: tuple[str, ...] = field(default=())
    params: SimParams | None = None

    def __repr__(self) -> str:
        return (f"Trajectory(model={self.model!r}, controller={self.gains.controller!r}, "
                f"samples={self.t.size}, horizon={self.t[-1]:g} s)")

    def _s(self, name: str) -> np.ndarray:
        return self.state[:, self.state_names.index(name)]

    def _o(self, name: str) -> np.ndarray:
        return self.outputs[:, self.output_names.index(name)]

    @property
    def xy(self) -> np.ndarray:
        """Horizontal position (north, east) [m], shape (N, 2)."""
        return self.state[:, [self.state_names.index("x"), self.state_names.index("y")]]

    @property
    def z_c(self) -> np.ndarray:
        """NNI controller state, shape (N, 2)."""
        return self.state[:, [self.state_names.index("zc_x"), self.state_names.index("zc_y")]]

    @property
    def phi(self) -> np.ndarray:
        """Roll [rad] (reduced models: the commanded roll, attitude assumed instant)."""
        return self._s("phi") if self.model == "full" else self._o("phi")

    @property
    def theta(self) -> np.ndarray:
        """Pitch [rad] (reduced models: the commanded pitch)."""
        return self._s("theta") if self.model == "full" else self._o("theta")

    @property
    def psi(self) -> np.ndarray | None:
        """Yaw [rad]; ``full`` only."""
        return self._s("psi") if self.model == "full" else None

    @property
    def z_ned(self) -> np.ndarray | None:
        """Altitude deviation, NED z [m] (positive = below the reference); ``full`` only."""
        return self._s("z") if self.model == "full" else None

    @property
    def cmd_tilt_deg(self) -> np.ndarray:
        """Commanded tilt [deg]."""
        return np.degrees(self._o("tilt_cmd"))

    @property
    def tilt_deg(self) -> np.ndarray:
        """Actual tilt arccos(cos φ cos θ) [deg]."""
        return tilt_deg(self.phi, self.theta)

    @property
    def rotor_speeds(self) -> np.ndarray | None:
        """Rotor speeds [rad/s], shape (N, 4); ``full`` only."""
        if self.model != "full":
            return None
        return self.outputs[:, [self.output_names.index(f"w{i}") for i in range(1, 5)]]

    @property
    def rotor_commands(self) -> np.ndarray | None:
        """Commanded rotor speeds [rad/s] (the allocator's, before the motor lag), shape (N, 4); ``full`` only."""
        if self.model != "full":
            return None
        return self.outputs[:, [self.output_names.index(f"wc{i}") for i in range(1, 5)]]

    @property
    def a_cmd(self) -> np.ndarray:
        """Commanded horizontal acceleration after the tilt limit [m/s²], shape (N, 2)."""
        return self.outputs[:, [self.output_names.index("a_x"), self.output_names.index("a_y")]]

    def metrics(self) -> Metrics:
        """All :class:`nniquad.sim.verdicts.Metrics` this run supports (altitude loss on ``full``)."""
        return compute_metrics(
            self.t,
            self.xy,
            phi=self.phi,
            theta=self.theta,
            cmd_tilt_deg=self.cmd_tilt_deg,
            tilt_limit_deg=self.options.tilt_limit_deg,
            rotor_speeds=self.rotor_speeds,
            z=self.z_ned,
            z_ref=0.0,
            follows_reference=self.options.reference is not None,
            rotor_commands=self.rotor_commands,
            omega_max=None if self.params is None else float(self.params.plant.omega_max),
        )

    def tracking(self, window_s: tuple[float, float] | None = None) -> TrackingMetrics | None:
        """The tracking metrics (:mod:`nniquad.sim.tracking`) of a run that follows a reference; ``None`` without one.

        Parameters
        ----------
        window_s
            ``(t0, t1)`` of the RMS and the maximum [s]; default the whole run.
        """
        ref = self.options.reference
        if ref is None:
            return None
        g = float(self.params.nominal.g) if self.params is not None else float(self.vehicle.g)
        return tracking_metrics(self.t, self.xy, ref, g=g, tilt_limit_deg=self.options.tilt_limit_deg,
                                window_s=window_s)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the trajectory atomically: ``.npz`` (arrays + names) or ``.csv`` (one column per signal).

        Parameters
        ----------
        path
            Destination ending in ``.npz`` or ``.csv``.
        """
        p = Path(path)
        cols = {"t": self.t}
        cols.update({n: self.state[:, i] for i, n in enumerate(self.state_names)})
        cols.update({f"out_{n}": self.outputs[:, i] for i, n in enumerate(self.output_names)})
        if p.suffix.lower() == ".csv":
            header = ",".join(cols)
            data = np.column_stack(list(cols.values()))

            def write_csv(tmp: Path) -> None:
                np.savetxt(tmp, data, delimiter=",", header=header, comments="", fmt="%.10g")

            return atomic_write_with(p, write_csv)
        if p.suffix.lower() != ".npz":
            raise SimulationError(f"trajectory file must end in .npz or .csv, got {p.name}")

        def write_npz(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, t=self.t, state=self.state, outputs=self.outputs,
                                    state_names=np.array(self.state_names), output_names=np.array(self.output_names),
                                    model=np.array(self.model))

        return atomic_write_with(p, write_npz)


@dataclass
class SimulationResult:
    """Every run of one :func:`nniquad.sim.simulate` call (they share model, horizon and sampling).

    Attributes
    ----------
    model
        ``"linear"``, ``"reduced"`` or ``"full"``.
    t : ndarray (N,)
        Sample times [s], starting at 0.
    states : ndarray (B, N, nx)
        States of the ``B`` runs, columns :attr:`state_names`.
    outputs : ndarray (B, N, ny)
        Outputs, columns :attr:`output_names`.
    state_names, output_names
        Signal names.
    gains
        The gain block of each run (all of one controller law).
    options
        The :class:`SimOptions` of each run.
    params
        The :class:`SimParams` of each run.
    vehicle
        The vehicle (``None`` when the runs were given as parameters only).

    Examples
    --------
    >>> res = simulate(PAPER_VEHICLE, [Gains(4, 20, 0.8), PAPER_GAINS], SimOptions(horizon_s=20))  # doctest: +SKIP
    >>> res.settling_s, res[0].metrics().peak_tilt_deg, res.plot("runs.png")  # doctest: +SKIP
    """

    model: str
    t: np.ndarray
    states: np.ndarray
    outputs: np.ndarray
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    gains: tuple[GainBlock, ...]
    options: tuple[SimOptions, ...]
    params: tuple[SimParams, ...]
    vehicle: Vehicle | None = None
    _metrics: list[Metrics] | None = field(default=None, repr=False, compare=False)

    # ---------------------------------------------------------------- runs

    def __len__(self) -> int:
        return self.states.shape[0]

    def __getitem__(self, i: int) -> Trajectory:
        """The view of run ``i`` (negative indices count from the end)."""
        n = len(self)
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise IndexError(f"run index {i!r} out of range for {n} runs")
        i = int(i) % n
        return Trajectory(self.model, self.options[i], self.gains[i], self.vehicle, self.t, self.states[i],
                          self.outputs[i], self.state_names, self.output_names, self.params[i])

    def __iter__(self) -> Iterator[Trajectory]:
        return (self[i] for i in range(len(self)))

    @property
    def controller(self) -> str:
        """The controller law of the runs."""
        return self.gains[0].controller

    def __repr__(self) -> str:
        return (f"SimulationResult(model={self.model!r}, controller={self.controller!r}, runs={len(self)}, "
                f"samples={self.t.size}, horizon={self.t[-1]:g} s)")

    # ---------------------------------------------------------------- signals

    def state(self, name: str) -> np.ndarray:
        """State ``name`` of every run, shape ``(B, N)``.

        Parameters
        ----------
        name
            A state name of :attr:`state_names` (e.g. ``"x"``, ``"phi"``).
        """
        if name not in self.state_names:
            raise SimulationError(f"no state '{name}' in the {self.model} model ({', '.join(self.state_names)})")
        return self.states[:, :, self.state_names.index(name)]

    def output(self, name: str) -> np.ndarray:
        """Output ``name`` of every run, shape ``(B, N)``.

        Parameters
        ----------
        name
            An output name of :attr:`output_names` (e.g. ``"tilt_cmd"``, ``"w1"``).
        """
        if name not in self.output_names:
            raise SimulationError(f"no output '{name}' in the {self.model} model ({', '.join(self.output_names)})")
        return self.outputs[:, :, self.output_names.index(name)]

    @property
    def xy(self) -> np.ndarray:
        """Horizontal positions (north, east) [m], shape ``(B, N, 2)``."""
        return self.states[:, :, [self.state_names.index("x"), self.state_names.index("y")]]

    @property
    def distance(self) -> np.ndarray:
        """Horizontal distance from the origin [m], shape ``(B, N)``."""
        xy = self.xy
        return np.hypot(xy[..., 0], xy[..., 1])

    @property
    def phi(self) -> np.ndarray:
        """Roll [rad], ``(B, N)`` (reduced models: the commanded roll)."""
        return self.state("phi") if self.model == "full" else self.output("phi")

    @property
    def theta(self) -> np.ndarray:
        """Pitch [rad], ``(B, N)`` (reduced models: the commanded pitch)."""
        return self.state("theta") if self.model == "full" else self.output("theta")

    @property
    def tilt_deg(self) -> np.ndarray:
        """Total tilt arccos(cos φ cos θ) [deg], ``(B, N)``."""
        return tilt_deg(self.phi, self.theta)

    @property
    def z_ned(self) -> np.ndarray | None:
        """Altitude deviation, NED z [m], ``(B, N)``; ``full`` only."""
        return self.state("z") if self.model == "full" else None

    # ---------------------------------------------------------------- metrics

    def metrics(self) -> list[Metrics]:
        """:meth:`Trajectory.metrics` of every run (computed once)."""
        if self._metrics is None:
            self._metrics = [tr.metrics() for tr in self]
        return list(self._metrics)

    @property
    def settling_s(self) -> np.ndarray:
        """Settling times [s] ``(B,)``; ``nan`` where not settled or diverged (as :class:`Metrics`)."""
        st = settling_time_batch(self.t, self.xy)
        return np.where(self.diverged, np.nan, st)

    @property
    def diverged(self) -> np.ndarray:
        """Lost-vehicle flags ``(B,)``: blown up, or altitude lost on ``full``
        (:func:`nniquad.sim.verdicts.diverged_batch`, as :attr:`Metrics.diverged`)."""
        return diverged_batch(self.xy, z_batch=self.z_ned)

    @property
    def altitude_lost(self) -> np.ndarray | None:
        """Altitude-loss flags ``(B,)`` (``full`` only, :func:`nniquad.sim.verdicts.altitude_lost_batch`)."""
        z = self.z_ned
        return None if z is None else altitude_lost_batch(z)

    def to_json(self) -> dict[str, Any]:
        """Model, gains, options and metrics of every run (no arrays)."""
        return {
            "model": self.model,
            "controller": self.controller,
            "runs": [{"gains": g.as_dict(), "options": o.to_json(), "metrics": m.to_json()}
                     for g, o, m in zip(self.gains, self.options, self.metrics())],
        }

    # ---------------------------------------------------------------- plot

    def plot(self, path: str | os.PathLike[str] | None = None, **kwargs: Any):
        """Distance and tilt of every run (:func:`nniquad.sim.plots.runs_plot`).

        Parameters
        ----------
        path
            PNG file to write; ``None`` only returns the figure.
        **kwargs
            Passed to :func:`nniquad.sim.plots.runs_plot` (``labels``, ``title``).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return runs_plot(self, path, **kwargs)
