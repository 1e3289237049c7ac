"""The control-law interface: what every horizontal law implements, and what the gain blocks share.

A law is one module of :mod:`nniquad.laws`: a frozen dataclass of its gains (a
:class:`GainBlock`), one :class:`ControlLaw` subclass that answers every question
the rest of the project asks about the law, and one call of
:func:`nniquad.laws.registry.register`.  The simulator, the tuner, the
certificate builder and verifier, the Monte Carlo study, the report, the export
and the command line ask the law; none of them branches on its name or on its
gains type (``docs/architecture.md``, "Adding a law").

The law, per axis
-----------------
Every law maps the measured position ``ξ_m`` [m] (and, for a law that measures
it, the velocity) to the horizontal acceleration command ``a_h`` [m/s²] through
a linear time-invariant system, written **once** in :meth:`ControlLaw.realisation`
as nested lists of entries built with ``+ - * /`` only, so that the same code
gives numbers (numpy), expressions (CasADi, the simulator) and symbols (sympy,
the audit).  The controller state of both axes is ordered state-major and
axis-minor, ``(s1_x, s1_y, s2_x, s2_y, ...)``, the order of the simulator's
state (:attr:`ControlLaw.sim_state_names`) and of the exported C.

Reference and feedforward
-------------------------
To follow a reference ``ξ_d(t)`` (:mod:`nniquad.control.references`) every law is fed the
error ``e = ξ_m - ξ_d`` in place of ``ξ_m`` (a law that measures the velocity also
``ξ̇ - ξ̇_d``), and the optional acceleration feedforward ``a_ff = ξ̈_d(t)``, read from the
reference (nothing is measured), is added to the law's command before the tilt limit:
``a_h = sat(a_law(e) + a_ff)``.  For every law it enters at that one point, the plant's
input, outside the controller: ``-k_p e + z/m̂ + a_ff`` for a law of the NI structure,
``-k_p e - k_d ė + a_ff`` for the PD laws.  The controller's realisation and state are
unchanged, and in the linear zone the error obeys the same loop the certificate analyses,
driven by the exogenous input ``r a_ff - ξ̈_d`` (``r = m̂/m``; zero for a perfect
feedforward on the nominal mass): ``ë = r a_law(e) + r a_ff - ξ̈_d``.  The reference and the
feedforward are inputs of the loop, not parts of it, so the stability claims (the
decay-rate and NI certificates, the margins) are untouched.  What the feedforward does
use is tilt authority: the limit acts on ``a_law + a_ff``, so the certificate's
nonlinear-region claims, made for a law that has the whole ``g_z tan(T_lim)`` to itself,
do not cover a run with feedforward unless the tilt the reference demands,
``atan(‖ξ̈_d‖/g)``, stays within a margin of the limit: only ``g_z tan(T_lim) - max ‖ξ̈_d‖``
is left to the law, and a region claim carries over only if it holds with that reduced
limit, which the certificate does not compute.

A start from motion (a velocity at ``t = 0``): a velocity-free law's state is a function
of the error's past alone, so its consistent state is its take-over state for the error
at the start, ``e_0 = ξ(0) - ξ_d(0)`` (:meth:`ControlLaw.start_state`: its static state for
an error held at ``e_0``; zero on the reference); the first command is then the law's static
command for ``e_0`` plus ``a_ff(0)``, which is the command of a vehicle that was following
the reference with that error, so the command continues without a jump.

Laws of the NI structure
------------------------
:class:`NILaw` is the paper's structure: a proportional inner loop reshapes
each axis into the lossless NI plant ``P(s) = 1/(m (s² + k_p))`` and a strictly
negative-imaginary controller ``C(s)`` (:meth:`NILaw.controller_realisation`,
input ``ξ`` [m], output the force ``z`` [N]) closes it in positive feedback,
``a_h = -k_p ξ + z/m̂``.  Its DC loop gain ``γ = C(0)/(m̂ k_p)`` is the sector
constant of the paper's theorem (:meth:`NILaw.sector_constant`); the reduced
loop (:class:`nniquad.analysis.reduced_loop.ReducedLoop`), the NI lemma LMIs,
the certificate and the cascade analysis need nothing else of the law.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, Field, field, fields
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.errors import GainError
from nniquad.validate import finite_number

__all__ = ["positive_gain", "gain_field", "field_unit", "field_symbol", "GainBlock", "ControlLaw", "NILaw",
           "gains_text", "wind_equilibrium_m",
           "both_axes", "dc_gain_of", "PlainGainBlock", "TuningBox", "AXES"]

#: The two horizontal axes (north, east), in the order of every pair.
AXES: tuple[str, str] = ("x", "y")


def positive_gain(name: str, value: float) -> float:
    """``value`` as a finite positive float, else :class:`GainError` naming ``name``.

    Parameters
    ----------
    name
        The gain's name, for the message.
    value
        The user's value.
    """
    return finite_number(name, value, error=GainError, positive=True)


def gain_field(unit: str, meaning: str, symbol: str | None = None, **kw: Any) -> Any:
    """A dataclass field of a gain block carrying its unit, its meaning and its symbol (tables and figures).

    Parameters
    ----------
    unit
        The unit (``"1/s^2"``, ``"-"``, ...).
    meaning
        What the gain is, in a few words.
    symbol
        How a figure title or table writes it (``"Γ"``); default the field's name.
    **kw
        Passed to :func:`dataclasses.field` (``default=...``).
    """
    meta = {"unit": unit, "meaning": meaning}
    if symbol is not None:
        meta["symbol"] = symbol
    return field(metadata=meta, **kw)


def field_unit(f: Field) -> tuple[str, str]:
    """``(unit, meaning)`` of a gain-block field (``("-", name)`` when it has none).

    Parameters
    ----------
    f
        A dataclass field.
    """
    return str(f.metadata.get("unit", "-")), str(f.metadata.get("meaning", f.name))


def field_symbol(f: Field) -> str:
    """How tables and figure titles write a gain (its ``symbol`` metadata, else its name).

    Parameters
    ----------
    f
        A dataclass field.
    """
    return str(f.metadata.get("symbol", f.name))


class GainBlock:
    """What every law's gains dataclass offers (mixed into a frozen dataclass).

    The class attribute ``controller`` names the law (its registry name); :attr:`law`
    is the registered :class:`ControlLaw` itself.
    """

    controller: ClassVar[str]
    #: Set by :func:`nniquad.laws.registry.register` on the law's gains type.
    _registered_law: ClassVar["ControlLaw | None"] = None

    @property
    def law(self) -> "ControlLaw":
        """The law these gains are for."""
        law = type(self)._registered_law
        if law is None:
            raise GainError(f"{type(self).__name__} belongs to no registered law")
        return law

    def values(self) -> dict[str, float]:
        """The numbers the simulator's parameter vector holds, in field order."""
        return {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]

    def as_dict(self) -> dict[str, float]:
        """Plain dictionary of the gains."""
        return self.values()

    @classmethod
    def from_values(cls, values: Mapping[str, float]) -> "GainBlock":
        """Inverse of :meth:`values`.

        Parameters
        ----------
        values
            ``{field: value}``.
        """
        return cls(**{f.name: values[f.name] for f in fields(cls)})  # type: ignore[arg-type]

    def axes(self) -> tuple[float, float]:
        """``(kpx, kpy)``: the position (inner-loop) gain of each axis; one gain for both unless the law has two."""
        kp = getattr(self, "kp")
        return kp, kp

    def time_scaled(self, factor: float) -> "GainBlock":
        """The same loop ``factor`` times faster (:attr:`ControlLaw.time_scaling` gives each gain's power of λ).

        Parameters
        ----------
        factor
            Speed-up λ > 0 (below 1: slower).
        """
        lam = positive_gain("time-scale factor", factor)
        powers = self.law.time_scaling
        scaled = {f.name: _power(getattr(self, f.name), lam, powers[f.name]) for f in fields(self)}  # type: ignore[arg-type]
        return type(self)(**scaled)


class PlainGainBlock(GainBlock):
    """A gain block whose fields are all plain positive numbers (checked on construction)."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            object.__setattr__(self, f.name, positive_gain(f.name, getattr(self, f.name)))


def both_axes(per_axis: Sequence[np.ndarray], inputs: int, n: int) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of both axes from each axis's ``(A, B, C, D)``, in the interleaved state order.

    Parameters
    ----------
    per_axis
        ``[(A, B, C, D) of x, (A, B, C, D) of y]`` (numpy arrays; one output, ``inputs`` inputs per axis).
    inputs
        Inputs per axis (1: the position; 2: position and velocity).
    n
        States per axis.
    """
    A, B, C, D = np.zeros((2 * n, 2 * n)), np.zeros((2 * n, 2 * inputs)), np.zeros((2, 2 * n)), np.zeros((2, 2 * inputs))
    for a, (Aa, Ba, Ca, Da) in enumerate(per_axis):
        s = [2 * i + a for i in range(n)]
        u = [2 * j + a for j in range(inputs)]
        A[np.ix_(s, s)], B[np.ix_(s, u)], C[np.ix_([a], s)], D[np.ix_([a], u)] = Aa, Ba, Ca, Da
    return A, B, C, D


def dc_gain_of(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> np.ndarray:
    """``D - C A⁻¹ B``: the static gain of a realisation (``inf`` entries where ``A`` is singular: an integrator).

    Parameters
    ----------
    A, B, C, D
        The realisation (numpy arrays).
    """
    if A.size == 0:
        return np.array(D, float)
    try:
        return D - C @ np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        return np.full(D.shape, math.inf)


class TuningBox:
    """What the tuner's box of a law may depend on: the vehicle's limits and the rates (one argument, not five).

    Attributes
    ----------
    kp_max
        Largest kp [1/s²] (:func:`nniquad.tuning.vehicle_limits.gain_limits`).
    pole_max
        Largest controller pole [1/s]: the Nyquist frequency of the control rate and the RK4 limit.
    control_rate_hz
        The control rate [Hz].
    rk4_pole_max
        Largest pole the RK4 step integrates [1/s].
    """

    def __init__(self, kp_max: float, pole_max: float, control_rate_hz: float, rk4_pole_max: float = math.inf):
        self.kp_max, self.pole_max = float(kp_max), float(pole_max)
        self.control_rate_hz, self.rk4_pole_max = float(control_rate_hz), float(rk4_pole_max)


class ControlLaw:
    """One horizontal control law: everything the project asks of it (module docstring).

    Subclasses set the class attributes and implement :meth:`realisation` and the tuning coordinates
    (:meth:`coordinates`, :meth:`box`, :meth:`decode`, :meth:`encode`); every other method has a
    default built from those.

    Attributes
    ----------
    name
        Registry name (``--controller``, the certificate's ``gains.controller``).
    title
        One line for ``--help``, tables and the docs.
    gains_type
        The law's :class:`GainBlock` dataclass.
    state_names
        The controller states of one axis, base names (the simulator appends ``_x``, ``_y``).
    state_units
        Their units.
    measures_velocity
        Whether the law reads the true horizontal velocity (a velocity sensor) besides the position.
    ni_structure
        Whether the paper's theorem applies: the law is a :class:`NILaw`.
    time_scaling
        Power of λ of each gain under :meth:`GainBlock.time_scaled` (``ξ_λ(t) = ξ(λ t)``).
    pole_label
        How the RK4 step check names the controller's fastest pole.
    pole_hint
        What to change when that pole is too fast (the Python API's names).
    law_classes
        The law classes (:mod:`nniquad.laws.classes`) the law can be tuned in; ``None`` is "no class".
    robust_budget_overrides
        Budgets of the robust objective that this law runs with another budget's numbers:
        ``{budget: (other budget, extra seeds or None to keep the other's)}``.
    start_description
        How a certificate's region-of-attraction note states the controller's start.
    controller_label
        How a certificate's cascade model text names the controller.
    display_name
        How exported code and reports name the law (default: its name).
    default_gains
        The gains a command uses when none are given (the paper's for the NNI law; ``None``: no default).
    integral
        Whether the law has integral action on the position (:mod:`nniquad.laws.integral`).
    """

    name: ClassVar[str]
    title: ClassVar[str]
    gains_type: ClassVar[type]
    state_names: ClassVar[tuple[str, ...]]
    state_units: ClassVar[tuple[str, ...]]
    measures_velocity: ClassVar[bool] = False
    ni_structure: ClassVar[bool] = False
    time_scaling: ClassVar[Mapping[str, int]]
    pole_label: ClassVar[str] = "controller"
    pole_hint: ClassVar[str] = "the controller's gains, or SimOptions.dt_s"
    law_classes: ClassVar[tuple[str | None, ...]] = (None,)
    robust_budget_overrides: ClassVar[Mapping[str, tuple[str, int | None]]] = {}
    start_description: ClassVar[str] = "controller state at the law's take-over value for the position"
    display_name: ClassVar[str] = ""
    default_gains: ClassVar["GainBlock | None"] = None
    controller_label: ClassVar[str] = "controller"
    integral: ClassVar[bool] = False

    # ------------------------------------------------------------------ gains
    def __init__(self) -> None:
        if not self.display_name:
            self.display_name = self.name

    def __repr__(self) -> str:
        return f"<law {self.name!r}: {self.title}>"

    @property
    def gain_names(self) -> tuple[str, ...]:
        """The gains' field names, in order."""
        return tuple(f.name for f in fields(self.gains_type))

    @property
    def inputs(self) -> int:
        """Measured signals per axis: the position, and the velocity for a law that measures it."""
        return 2 if self.measures_velocity else 1

    @property
    def n_states(self) -> int:
        """Controller states per axis."""
        return len(self.state_names)

    @property
    def sim_state_names(self) -> tuple[str, ...]:
        """The controller states of both axes as the simulator names them, state-major: ``zc_x, zc_y, ...``."""
        return tuple(f"{s}_{a}" for s in self.state_names for a in AXES)

    def gains(self, values: Any) -> GainBlock:
        """A gain block of this law from a block, a mapping or a tuple of the fields (one-line errors).

        Parameters
        ----------
        values
            A block of this law (returned as it is), a ``{field: value}`` mapping, or a sequence in field order.

        Raises
        ------
        GainError
            Missing, unknown, non-finite or non-positive gains, or a block of another law.
        """
        cls = self.gains_type
        if isinstance(values, GainBlock):
            if type(values) is not cls:
                raise GainError(f"{type(values).__name__} ({values.controller}) given where {self.name} gains are "
                                f"needed (use {cls.__name__})")
            return values
        names = list(self.gain_names)
        required = [f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING]
        label = f"a {self.name} gain set"
        if isinstance(values, Mapping):
            unknown = [k for k in values if k not in names]
            if unknown:
                raise GainError(f"{label} has no gain '{unknown[0]}' (gains: {', '.join(names)})")
            missing = [k for k in required if k not in values]
            if missing:
                raise GainError(f"{label} lacks '{missing[0]}'")
            return cls(**values)
        if isinstance(values, (str, bytes)):
            raise GainError(f"cannot read {label} from {values!r}")
        try:
            vals = list(values)
        except TypeError:
            raise GainError(f"cannot read {label} from {values!r}") from None
        if not len(required) <= len(vals) <= len(names):
            raise GainError(f"{label} tuple is ({', '.join(names)}) with {len(required)} to {len(names)} values, "
                            f"got {len(vals)}")
        return cls(*vals)

    def gains_json(self, gains: GainBlock) -> dict[str, Any]:
        """The certificate's ``gains`` section: ``{"controller": name, field: value, ...}``.

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return {"controller": self.name, **gains.values()}

    #: The key of the certificate's ``gains`` section that names the law.
    SECTION_LAW_KEY: ClassVar[str] = "controller"

    @property
    def section_fields(self) -> tuple[str, ...]:
        """The gains the certificate's ``gains`` section holds (:meth:`gains_json`), besides the law's name."""
        return self.gain_names

    def gains_from_json(self, section: Mapping[str, Any]) -> GainBlock:
        """The gains of a certificate's ``gains`` section (inverse of :meth:`gains_json`; every key checked).

        Parameters
        ----------
        section
            The section's mapping.

        Raises
        ------
        GainError
            A key that is not a gain of the section, a gain missing, or a gain that is not a positive number.
        """
        keys = [k for k in section if k != self.SECTION_LAW_KEY]
        unknown = [k for k in keys if k not in self.section_fields]
        if unknown:
            raise GainError(f"'{unknown[0]}' is not a gain of the {self.name} law ({', '.join(self.section_fields)})")
        required = [f.name for f in fields(self.gains_type) if f.default is MISSING and f.default_factory is MISSING]
        missing = [k for k in required if k not in section]
        if missing:
            raise GainError(f"lacks '{missing[0]}'")
        try:
            return self.gains_type(**{k: section[k] for k in keys})
        except TypeError as exc:
            raise GainError(str(exc)) from None

    def gains_text(self, gains: GainBlock, *, sep: str = " ", greek: bool = False, number: Any = None) -> str:
        """One line of the gains' numbers, ``name=value`` (messages, tables, figure titles).

        Parameters
        ----------
        gains
            A gain block of this law.
        sep
            Separator of the entries.
        greek
            The fields' symbols (``Γ, δ, ω, ζ, τ_f``) for the names, and a second-axis gain equal to the first
            left out (figure titles).
        number
            Formats a value (default ``format(v, "g")``).
        """
        fmt_ = number or (lambda v: f"{v:g}")
        symbol = {f.name: field_symbol(f) for f in fields(self.gains_type)}
        items = gains.as_dict()
        if greek and items.get("kpy") == items.get("kp"):
            items = {k: v for k, v in items.items() if k != "kpy"}
        return sep.join(f"{symbol.get(k, k) if greek else k}={fmt_(v)}" for k, v in items.items() if v is not None)

    # ------------------------------------------------------------------ realisation
    def parameters(self, gains: GainBlock, m_hat: float) -> dict[str, float]:
        """The entries :meth:`realisation` reads: every gain (the second axis resolved) and ``m_hat``.

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        return {**gains.values(), "m_hat": float(m_hat)}

    def realisation(self, p: Mapping[str, Any], axis: int = 0) -> tuple[list, list, list, list]:
        """``(A, B, C, D)`` of one axis as nested lists of entries: input ``ξ_m`` [m] (and the velocity [m/s]),
        output ``a_h`` [m/s²].  Entries are built with ``+ - * /`` from ``p``, so numbers, CasADi expressions and
        sympy symbols all work.

        Parameters
        ----------
        p
            The gains by field name and ``m_hat`` (:meth:`parameters`, or symbols).
        axis
            0 (x, north) or 1 (y, east).
        """
        raise NotImplementedError

    def matrices(self, gains: GainBlock, m_hat: float, axis: int = 0) -> tuple[np.ndarray, ...]:
        """Numeric ``(A, B, C, D)`` of one axis (:meth:`realisation`).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        axis
            0 or 1.
        """
        return _arrays(self.realisation(self.parameters(gains, m_hat), axis), self.n_states, self.inputs)

    def both_axes(self, gains: GainBlock, m_hat: float) -> tuple[np.ndarray, ...]:
        """Numeric ``(A, B, C, D)`` of both axes, states interleaved (:func:`both_axes`).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        return both_axes([self.matrices(gains, m_hat, a) for a in (0, 1)], self.inputs, self.n_states)

    def symbolic_realisation(self, axis: int = 0) -> tuple[Any, Any, Any, Any]:
        """``(A, B, C, D)`` of one axis as sympy matrices of positive symbols named after the gains and ``m_hat``.

        Parameters
        ----------
        axis
            0 or 1.
        """
        import sympy as sp  # lazily: the audit and the tests need sympy, a cold command does not

        p = {n: sp.Symbol(n, positive=True) for n in (*self.gain_names, "m_hat")}
        rows = self.realisation(p, axis)
        shapes = ((self.n_states, self.n_states), (self.n_states, self.inputs), (1, self.n_states),
                  (1, self.inputs))
        return tuple(sp.Matrix(*shape, [e for r in M for e in r]) if shape[0] * shape[1] else sp.zeros(*shape)
                     for M, shape in zip(rows, shapes))

    # ------------------------------------------------------------------ discrete time
    def zoh(self, gains: GainBlock, m_hat: float, T: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact zero-order-hold ``(A_d, B_d)`` of both axes over the period ``T`` [s] (``scipy.linalg.expm`` of
        the augmented matrix; a law with a closed form may override it).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        T
            Sample period [s].
        """
        import scipy.linalg as sla  # lazily: scipy.linalg costs a cold `nniquad --help` a tenth of a second

        A, B, _, _ = self.both_axes(gains, m_hat)
        n, m = A.shape[0], B.shape[1]
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A * T, B * T
        E = sla.expm(M)
        return E[:n, :n], E[:n, n:]

    def zoh_entries(self, p: Mapping[str, Any], T: Any, lib: Any, axis: int = 0) -> tuple[list, list]:
        """``(A_d, B_d)`` of one axis over ``T`` as entries of ``lib`` (CasADi: the simulator's discrete variant).

        The default is a scaling-and-squaring Taylor series of the augmented matrix (``2⁻¹⁰`` of ``T``,
        order 8: relative error below 1e-15 while ``‖A‖ T <= 40``); a law with a closed form overrides it.

        Parameters
        ----------
        p
            The gains by name and ``m_hat`` (entries of ``lib``).
        T
            Sample period [s] (an entry of ``lib``).
        lib
            A module with CasADi's matrix interface (``casadi``).
        axis
            0 or 1.
        """
        A, B, _, _ = self.realisation(p, axis)
        n, m = self.n_states, self.inputs
        M = lib.SX.zeros(n + m, n + m)
        for i in range(n):
            for j in range(n):
                M[i, j] = A[i][j] * T
            for j in range(m):
                M[i, n + j] = B[i][j] * T
        squarings, order = 10, 8
        X = M / (2.0 ** squarings)
        E, term = lib.SX.eye(n + m), lib.SX.eye(n + m)
        for k in range(1, order + 1):
            term = lib.mtimes(term, X) / k
            E = E + term
        for _ in range(squarings):
            E = lib.mtimes(E, E)
        return ([[E[i, j] for j in range(n)] for i in range(n)], [[E[i, n + j] for j in range(m)] for i in range(n)])

    def discretisation_text(self) -> str:
        """How ``nniquad export`` states the discretisation of this law (:meth:`zoh`)."""
        return (f"exact zero-order hold of the {self.name} law's realisation (scipy.linalg.expm of the augmented "
                f"matrix); state order {', '.join(self.sim_state_names)}")

    def export_matrix_units(self) -> dict[str, str]:
        """The units of the exported matrices ``A, B, C, D`` (state units from :attr:`state_units`)."""
        u = ", ".join(self.state_units) or "-"
        return {"A": f"- (states in {u})", "B": f"({u})/m", "C": f"(m/s^2)/({u})", "D": "1/s^2"}

    # ------------------------------------------------------------------ the simulator
    def sim_rates(self, p: Mapping[str, Any], meas: Sequence[Any], vel: Sequence[Any], xc: Sequence[Any],
                  discrete: Any, lib: Any) -> tuple[list, list]:
        """The command and the state derivative of the continuous law, both axes (entries of the simulator's lib).

        The simulator holds the states constant between samples when the law runs in discrete time
        (``discrete``); the derivative returned here is that of the continuous law.

        Parameters
        ----------
        p
            The gains by name and ``m_hat``.
        meas
            The measured (or held) position, ``(x, y)``.
        vel
            The true velocity, ``(x', y')`` (read only by a law that measures it).
        xc
            The controller states, interleaved (:attr:`sim_state_names`).
        discrete
            True when the law runs in discrete time.
        lib
            ``casadi``.

        Returns
        -------
        a_h, xc_dot
            Two command entries, and ``2 n`` derivative entries in the state order.
        """
        n = self.n_states
        a_h, dx = [], [None] * (2 * n)
        for a in (0, 1):
            A, B, C, D = self.realisation(p, a)
            x = [xc[2 * i + a] for i in range(n)]
            u = [meas[a], vel[a]][: self.inputs]
            a_h.append(_affine(C[0], x, D[0], u))
            for i in range(n):
                dx[2 * i + a] = _affine(A[i], x, B[i], u)
        return a_h, dx

    def anti_windup_gains(self, p: Mapping[str, Any], axis: int = 0) -> list | None:
        """The anti-windup gains of one axis: the controller states' derivative gets them times the axis's excess
        ``a_h - sat(a_h)`` of the tilt limit (the discrete law ``T`` times them); ``None``: no anti-windup.

        Parameters
        ----------
        p
            The gains by name and ``m_hat`` (numbers or expressions).
        axis
            0 or 1.
        """
        return None

    def sim_sample(self, p: Mapping[str, Any], xc: Sequence[Any], held: Sequence[Any], vel: Sequence[Any],
                   T: Any, sample: Any, advance: Any, lib: Any) -> list:
        """The controller state after a sample instant of the discrete law (entries of ``lib``).

        At a later sample (``advance``) the state advances one period on the value held over it; the first
        sample only latches the measurement (the simulator does that).

        Parameters
        ----------
        p
            The gains by name and ``m_hat``.
        xc
            The controller states, interleaved.
        held
            The measurement held over the period that ends.
        vel
            The true velocity now.
        T
            The sample period [s].
        sample
            True at every sample instant of the discrete law.
        advance
            True at a later sample instant of the discrete law.
        lib
            ``casadi``.
        """
        n = self.n_states
        out = [None] * (2 * n)
        for a in (0, 1):
            Ad, Bd = self.zoh_entries(p, T, lib, a)
            x = [xc[2 * i + a] for i in range(n)]
            u = [held[a], vel[a]][: self.inputs]
            for i in range(n):
                out[2 * i + a] = lib.if_else(advance, _affine(Ad[i], x, Bd[i], u), xc[2 * i + a])
        return out

    def start_state(self, gains: GainBlock, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        """The controller state at take-over from rest at the measured position ``ξ(0)`` (both axes, interleaved).

        The default is the law's static state for that position, ``x_c = -A⁻¹ B ξ(0)`` (the command then starts
        at the law's static stiffness, without a kick), or zero where ``A`` is singular.

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        xi0
            The position measured at take-over [m] (north, east).
        """
        out = np.zeros(2 * self.n_states)
        for a in (0, 1):
            A, B, _, _ = self.matrices(gains, m_hat, a)
            if A.size == 0:
                continue
            try:
                xs = -np.linalg.solve(A, B[:, :1]) * float(xi0[a])
            except np.linalg.LinAlgError:
                continue
            out[a::2] = xs[:, 0]
        return out

    def sim_start_state(self, gains: GainBlock, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        """The simulator's controller states at the start (:attr:`sim_state_names`): :meth:`start_state`.

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        xi0
            The position at the start [m].
        """
        return self.start_state(gains, m_hat, xi0)

    def start_map(self, gains: GainBlock, m_hat: float) -> np.ndarray:
        """The matrix ``S`` (``2n x 2``) with :meth:`start_state` ``= S ξ(0)`` (linear in the position).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        return np.stack([self.start_state(gains, m_hat, col) for col in np.eye(2)], axis=1)

    def starts_at_zero(self, gains: GainBlock, m_hat: float) -> bool:
        """Whether the controller starts at zero whatever the position (what the Lur'e region assumes).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        return not np.any(self.start_map(gains, m_hat))

    def controller_poles(self, gains: GainBlock, m_hat: float) -> np.ndarray:
        """The eigenvalues of the law's state matrix, both axes [1/s].

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        A = self.both_axes(gains, m_hat)[0]
        return np.linalg.eigvals(A) if A.size else np.zeros(0)

    def fastest_pole(self, gains: GainBlock, m_hat: float = 1.0) -> float | None:
        """``max |λ|`` of the controller [1/s] (the RK4 step check), ``None`` for a law without state dynamics.

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg] (the state matrix of the project's laws does not depend on it).
        """
        poles = self.controller_poles(gains, m_hat)
        return float(np.max(np.abs(poles))) if poles.size and np.any(poles) else None

    # ------------------------------------------------------------------ statics
    def static_stiffness(self, gains: GainBlock, m_hat: float) -> tuple[float, float]:
        """The static stiffness per axis [N/m]: the force that holds the vehicle 1 m off at rest, ``-m̂ G(0)`` with
        ``G(0)`` the law's DC gain from position to command (``inf`` with integral action).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        out = []
        for a in (0, 1):
            G0 = dc_gain_of(*self.matrices(gains, m_hat, a))
            out.append(-float(m_hat) * float(G0[0, 0]))
        return out[0], out[1]

    def wind_equilibrium(self, gains: GainBlock, m_hat: float, wind_N: Sequence[float]) -> tuple[float, float]:
        """Static position under a constant horizontal force ``F``: ``F/k`` per axis (:meth:`static_stiffness`;
        the origin where ``k`` is not positive or infinite).

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            Mass the controller assumes [kg].
        wind_N
            Constant force ``(F_x, F_y)`` [N].
        """
        k = self.static_stiffness(gains, m_hat)
        x, y = (f / s if 0 < s < math.inf else 0.0 for f, s in zip(wind_N, k))
        return (x, y)

    # ------------------------------------------------------------------ the NI structure
    def ni_image(self, gains: GainBlock, m_hat: float) -> GainBlock | None:
        """The gains of a law of the NI structure that is this design (itself for such a law), or ``None``.

        Parameters
        ----------
        gains
            A gain block of this law.
        m_hat
            The controller's nominal mass [kg].
        """
        return None

    @staticmethod
    def image_of(gains: GainBlock, m_hat: float) -> GainBlock | None:
        """The NNI-structure image of any law's design (:meth:`ni_image` of its law), ``None`` where it has none.

        Parameters
        ----------
        gains
            A gain block of any law.
        m_hat
            The controller's nominal mass [kg].
        """
        try:
            return gains.law.ni_image(gains, m_hat)
        except GainError:
            return None

    def seed_from(self, gains: GainBlock, m_hat: float) -> GainBlock | None:
        """A design of this law that starts the tuner from another law's design (``None``: no such design).

        Parameters
        ----------
        gains
            A gain block of any law.
        m_hat
            The controller's nominal mass [kg].
        """
        return gains if isinstance(gains, self.gains_type) else None

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        """Names of the tuner's gain coordinates in a law class.

        Parameters
        ----------
        law_class
            ``"paper"``, ``"cascade"`` or ``None``.
        """
        raise NotImplementedError

    def dims(self, law_class: str | None = None) -> int:
        """Number of gain coordinates.

        Parameters
        ----------
        law_class
            As in :meth:`coordinates`.
        """
        return len(self.coordinates(law_class))

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        """Lower and upper ends of the gain coordinates.

        Parameters
        ----------
        law_class
            As in :meth:`coordinates`.
        limits
            What the vehicle and the rates allow.
        """
        raise NotImplementedError

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> GainBlock:
        """Gain coordinates -> gains (only the first :meth:`dims` entries of ``q`` are read).

        Parameters
        ----------
        q
            The coordinates.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        law_class
            As in :meth:`coordinates`.
        """
        raise NotImplementedError

    def encode(self, gains: GainBlock, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        """Gains -> gain coordinates (inverse of :meth:`decode`).

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        law_class
            As in :meth:`coordinates`.

        Raises
        ------
        ValueError
            A gain block of another law, or gains outside the class's coordinates.
        """
        raise NotImplementedError

    def sector_face(self, law_class: str | None) -> bool:
        """Whether the fastest designs sit on the face ``q1 = lo`` of the box (the sector bound).

        Parameters
        ----------
        law_class
            As in :meth:`coordinates`.
        """
        return False

    def image_violation(self, gains: GainBlock, m: float, gamma_max: float, law_class: str | None,
                        limits: TuningBox) -> float:
        """How far a design lies outside its class's bounds when it is tuned through its NNI image (0 inside).

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        law_class
            As in :meth:`coordinates`.
        limits
            The box's limits.
        """
        return 0.0

    @property
    def certifiable(self) -> bool:
        """Whether a design of this law can be certified: the law is of the NI structure, or a class takes it
        through its NNI image (:meth:`ni_image`)."""
        return self.ni_structure or any(c is not None for c in self.law_classes)

    def in_class(self, law_class: str | None) -> bool:
        """Whether a design tuned in ``law_class`` is a design of the NI structure (itself or its image).

        Parameters
        ----------
        law_class
            As in :meth:`coordinates`.
        """
        return self.ni_structure or law_class is not None

    def check_class(self, law_class: str | None) -> str | None:
        """The class a design of this law is tuned in (``None`` resolved to the law's default), or an error.

        Parameters
        ----------
        law_class
            The requested class.

        Raises
        ------
        ValueError
            A class this law cannot be tuned in (one line).
        """
        if law_class is None:
            return self.law_classes[0]
        if law_class not in self.law_classes:
            raise ValueError(f"the {self.name} law has no law class {law_class!r}"
                             + ("" if self.law_classes != (None,) else ": it is no NNI law"))
        return law_class


class NILaw(ControlLaw):
    """A law of the paper's NI structure: ``a_h = -k_p ξ + z/m̂`` with ``z = C(s) ξ`` strictly negative imaginary.

    Subclasses implement :meth:`controller_realisation` (``C(s)``, input ``ξ`` [m], output ``z`` [N]) and
    :meth:`sector_limit`; the command's realisation, the DC gain, the sector constant and the start state follow.
    """

    ni_structure: ClassVar[bool] = True
    law_classes: ClassVar[tuple[str | None, ...]] = ("paper", "cascade")
    #: The sector constant in words, as refusals and tables print it.
    gamma_formula: ClassVar[str] = "C(0)/(m kp)"

    def kp(self, p: Mapping[str, Any], axis: int = 0) -> Any:
        """The inner-loop gain of an axis [1/s²] (one gain for both unless a law has two).

        Parameters
        ----------
        p
            The gains by name.
        axis
            0 or 1.
        """
        return p["kp"]

    def controller_realisation(self, p: Mapping[str, Any]) -> tuple[list, list, list, list]:
        """``(A_c, B_c, C_c, D_c)`` of the SNI controller ``C(s)`` of one axis (input ξ [m], output z [N]).

        Parameters
        ----------
        p
            The gains by name (numbers, CasADi expressions or sympy symbols).
        """
        raise NotImplementedError

    def controller_matrices(self, gains: GainBlock) -> tuple[np.ndarray, ...]:
        """Numeric ``(A_c, B_c, C_c, D_c)`` of :meth:`controller_realisation`.

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return _arrays(self.controller_realisation(gains.values()), self.n_states, 1)

    def realisation(self, p: Mapping[str, Any], axis: int = 0) -> tuple[list, list, list, list]:
        Ac, Bc, Cc, Dc = self.controller_realisation(p)
        m = p["m_hat"]
        return (Ac, Bc, [[c / m for c in Cc[0]]], [[-self.kp(p, axis) + _scaled(Dc[0][0], m)]])

    def sim_rates(self, p: Mapping[str, Any], meas: Sequence[Any], vel: Sequence[Any], xc: Sequence[Any],
                  discrete: Any, lib: Any) -> tuple[list, list]:
        # the paper's form -k_p ξ + z/m̂ with z = C_c x_c (the simulator's expression since the first release)
        n = self.n_states
        Ac, Bc, Cc, _ = self.controller_realisation(p)
        a_h, dx = [], [None] * (2 * n)
        for a in (0, 1):
            x = [xc[2 * i + a] for i in range(n)]
            z = _affine(Cc[0], x, [], [])
            a_h.append(-self.kp(p, a) * meas[a] + z / p["m_hat"])
            for i in range(n):
                dx[2 * i + a] = _affine(Ac[i], x, Bc[i], [meas[a]])
        return a_h, dx

    def dc_gain(self, gains: GainBlock) -> float:
        """``C(0)`` [N/m], the controller's static gain.

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return float(dc_gain_of(*self.controller_matrices(gains))[0, 0])

    def sector_constant(self, gains: GainBlock, m: float) -> float:
        """The sector constant γ: the DC loop gain ``P(0) C(0) = C(0)/(m k_p)`` of the weaker axis (stable iff < 1).

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            The (true) mass of the reduced loop [kg].
        """
        return max(self.dc_loop_gain(gains, m, kp) for kp in gains.axes())

    def dc_loop_gain(self, gains: GainBlock, m: float, kp: float) -> float:
        """``C(0)/(m kp)``: the DC loop gain of one axis with inner gain ``kp``.

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            The mass of the reduced loop [kg].
        kp
            The axis's (effective) inner gain [1/s²].
        """
        return self.dc_gain(gains) / (float(m) * float(kp))

    def sector_limit(self, gains: GainBlock, m: float, kp: float, gamma: float) -> tuple[str, float]:
        """The bound the sector constant ``γ`` puts on the law's own gain: ``(certificate key, value)``.

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            The mass of the reduced loop [kg].
        kp
            The (weaker axis's) inner gain [1/s²].
        gamma
            The sector constant, in (0, 1).
        """
        raise NotImplementedError

    def sector_violation(self, gains: GainBlock, m: float, gamma_max: float) -> str:
        """Why ``gains`` violate the sector bound with ``γ_max``, in one clause with the numbers.

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            The vehicle's mass [kg].
        gamma_max
            The sector bound's ceiling.
        """
        key, limit = self.sector_limit(gains, m, min(gains.axes()), gamma_max)
        return (f"{key} = {limit:.6g} is exceeded (DC loop gain {self.gamma_formula} = "
                f"{self.sector_constant(gains, m):.6g} > gamma_max {gamma_max:g})")

    def ni_image(self, gains: GainBlock, m_hat: float) -> GainBlock:
        return gains

    def static_stiffness(self, gains: GainBlock, m_hat: float) -> tuple[float, float]:
        # the controller settles at z = C(0) ξ: the stiffness m̂ k_p - C(0) per axis
        c0 = self.dc_gain(gains)
        kx, ky = gains.axes()
        return float(m_hat) * kx - c0, float(m_hat) * ky - c0

    def controller_scaling(self, gains: GainBlock) -> np.ndarray:
        """Diagonal state scaling of the controller for its NI lemma LMI (identity unless a law needs one).

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return np.eye(self.n_states)

    def controller_normalisation(self, gains: GainBlock) -> tuple[np.ndarray, float]:
        """``(T, time scale)`` in which ``verify`` judges the controller's NI storage.

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return self.controller_scaling(gains), 1.0

    def axis_scaling(self, gains: GainBlock, kp: float, m_nominal: float) -> np.ndarray:
        """Diagonal state scaling ``[ξ, ξ', controller states]`` of one axis for the decay LMIs.

        Parameters
        ----------
        gains
            A gain block of this law.
        kp
            The axis's inner gain [1/s²].
        m_nominal
            The nominal mass [kg].
        """
        return np.diag([1.0, float(np.sqrt(kp))] + [1.0] * self.n_states)

    def pm_ceiling_deg(self, gamma_max: float) -> float:
        """Largest phase margin the law can have on a pure double integrator under the sector bound [deg]
        (180 where the sector bound leaves it unbounded).

        The ``sni2`` law keeps this default: it is ``k_p (s² + 2ζωs + ω²(1 - γ))/(s² + 2ζωs + ω²)``; between the
        frequencies ``ω sqrt(1 - γ)`` and ``ω`` of its zero and pole pairs the phase of the numerator exceeds 90°
        and that of the denominator stays below it, and as ``ζ → 0`` the lead there tends to 180° for any
        ``γ > 0``.

        Parameters
        ----------
        gamma_max
            The sector bound's ceiling.
        """
        return 180.0

    def min_stable_mass(self, gains: GainBlock) -> float:
        """Smallest true mass of the paper's reduced model that keeps the loop stable, ``C(0)/min k_p`` [kg].

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return self.dc_gain(gains) / min(gains.axes())


# ----------------------------------------------------------------------------- helpers


def _power(value: float | None, lam: float, power: int) -> float | None:
    """``value λ^power`` (a division for a negative power: the rounding of ``δ/λ²``), ``None`` kept."""
    if value is None or power == 0:
        return value
    return value * lam**power if power > 0 else value / lam ** (-power)


def _scaled(d: Any, m: Any) -> Any:
    """``d/m`` unless ``d`` is the number 0 (no term at all: the simulator's expressions stay as they were)."""
    return 0.0 if isinstance(d, (int, float)) and d == 0 else d / m


def _affine(row: Sequence[Any], x: Sequence[Any], row_u: Sequence[Any], u: Sequence[Any]) -> Any:
    """``row · x + row_u · u``, leaving out the terms whose coefficient is the number 0."""
    total: Any = None
    for c, v in list(zip(row, x)) + list(zip(row_u, u)):
        if isinstance(c, (int, float)) and c == 0:
            continue
        term = v if isinstance(c, (int, float)) and c == 1 else c * v
        total = term if total is None else total + term
    return 0.0 if total is None else total


def _arrays(rows: tuple[list, list, list, list], n: int, inputs: int) -> tuple[np.ndarray, ...]:
    A, B, C, D = rows
    return (np.array(A, float).reshape(n, n), np.array(B, float).reshape(n, inputs),
            np.array(C, float).reshape(1, n), np.array(D, float).reshape(1, inputs))


def gains_text(gains: GainBlock, *, sep: str = " ", greek: bool = False, number: Any = None) -> str:
    """One line of a gain block's numbers, ``name=value`` (:meth:`ControlLaw.gains_text` of its law).

    Parameters
    ----------
    gains
        Any law's gain block.
    sep
        Separator of the entries.
    greek
        The fields' symbols for the names (figure titles).
    number
        Formats a value (default ``format(v, "g")``).
    """
    return gains.law.gains_text(gains, sep=sep, greek=greek, number=number)


def wind_equilibrium_m(gains: GainBlock, m_hat: float, wind_N: Sequence[float]) -> tuple[float, float]:
    """Static position under a constant horizontal force (:meth:`ControlLaw.wind_equilibrium` of the gains' law).

    Parameters
    ----------
    gains
        Any law's gain block.
    m_hat
        Mass the controller assumes [kg].
    wind_N
        Constant force ``(F_x, F_y)`` [N].
    """
    return gains.law.wind_equilibrium(gains, m_hat, wind_N)
