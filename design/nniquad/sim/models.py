"""Closed-loop simulation of the reduced horizontal loop and of the full 12-state vehicle.

Models
------
``linear``
    The paper's reduced horizontal loop, both axes, no limits: per axis
    ``ξ'' = a``, ``a = -k_p ξ_m + z/m̂``, ``z' = -Γδ z + Γ ξ_m`` (positive
    feedback of the NNI controller output ``z``), ``ξ_m`` the measured position.
``reduced``
    The same, with the horizontal command norm-limited by the tilt limit,
    ``‖a_h‖ ≤ g tan(T_lim)`` (default 30°): the attitude is assumed to follow
    its setpoint instantly.
``full``
    The 12-state vehicle (:func:`nniquad.model.numeric.dynamics_function` ``"exact"``,
    NED, rotor gyroscopic terms; with motor lag also the rotor spin-up reaction torque
    ``-Jr dΩ_r/dt`` about ``z_B``, :func:`nniquad.model.symbolic.rotor_reaction_torque`)
    with rotor-speed saturation, the mixer of the vehicle's frame ('+' or 'x', selected by the
    parameter vector: :func:`nniquad.model.numeric.mixer_function`), and the loops of
    :mod:`nniquad.control.inner_loops` (altitude PID, yaw hold, attitude PD with gyro
    rates, tilt limit, saturation-aware allocation).  The horizontal command is
    the paper's ``a_h = -K_p ξ_m + z/m̂``.  No horizontal velocity is used.

In every model the true mass ``m`` may differ from the controller's nominal
mass ``m̂``.  The command is an acceleration that the thrust vector realises with
``m̂``, so the plant sees ``ξ'' = (m̂/m) a_h + F_wind/m`` (``reduced``/``linear``;
the ``full`` model produces the same factor through ``u1 = m̂ g_z / cos``).
Note that :mod:`nniquad.analysis.reduced_loop` models a mass error differently (``k_p`` as an
exact acceleration gain, only ``z`` divided by the true mass); with ``m = m̂``
both agree.

Horizontal controllers
----------------------
The type of the gain block picks the law (:mod:`nniquad.laws`: the registry
maps its name to a :class:`~nniquad.laws.base.ControlLaw`), and the law writes
the command ``a_h`` (before the tilt limit) and its state derivative once, in
:meth:`~nniquad.laws.base.ControlLaw.sim_rates`, from its realisation; the same
expressions serve every model.  The paper's law is ``a_h = -k_p ξ_m + z/m̂``,
``z' = -Γδ z + Γ ξ_m``; the PD law with the true velocity reads the velocity;
the others are velocity-free.  No horizontal velocity is used by a
velocity-free law.

Controller sampling
-------------------
``run.sample_hold = 1`` feeds every law the measurement sampled at the sensor
rate and held (``ξ_m`` above = the held value).  With ``run.discrete = 1`` the
law also runs in discrete time at that rate (period ``run.sample_period``):
its state is constant over a period and :func:`step_function` advances it at
each later sample by the exact ZOH equivalent of the period that ends
(:meth:`~nniquad.laws.base.ControlLaw.sim_sample`, the law's own closed form
where it has one), before it latches the new measurement, so ``a_h`` is held
over the period.

Anti-windup
-----------
A law with anti-windup gains (:meth:`~nniquad.laws.base.ControlLaw.anti_windup_gains`, the
integral laws of :mod:`nniquad.laws.integral`) gets them times the tilt limit's excess
``a_h - sat(a_h)`` of the total command (feedforward included) added to its state
derivative; ``linear`` has no limit, so no excess.  In discrete time the sample update
adds ``T`` times them times the excess of the command held over the period that ends,
recomputed at the sample from the state and the measurement held over it.  That is the
certified discrete law ``q⁺ = q + T (ξ_k + ψ_k/k_s)`` exactly on ``reduced`` with a constant
(or no) feedforward; a changing feedforward, and on ``full`` the limit ``g_z tan(T_lim)``,
are read at the new sample, one period late.

References and feedforward
--------------------------
The law acts on the error to the reference, ``ξ_m - ξ_d`` (and a law that measures the
velocity on ``ξ̇ - ξ̇_d``), the reference read when the measurement is read (latched with
it when sampled).  The optional acceleration feedforward ``a_ff = ξ̈_d`` is added to the
law's command *before* the tilt limit, so the limit still bounds the commanded tilt.
Both are columns of the exogenous input (:data:`EXO_FIELDS`), not parameters: one
compiled function serves every reference, and with none (zeros) every expression gives
exactly the numbers it gave before.  Why the feedforward leaves the certificate's claims as
they are, and where it does not: :mod:`nniquad.laws.base`, "Reference and feedforward".

Every law has its own parameter layout (:func:`nniquad.sim.params.param_layout`,
the gain entries named after the block's fields), its own state layout
(:func:`nniquad.sim.params.state_names`) and its own compiled function.  Before
every run the RK4 step is checked against the law's fastest pole
(:mod:`nniquad.sim.step_check`).

Integration
-----------
Fixed-step classical Runge-Kutta (RK4), built once per model and law as a
CasADi ``SX`` function of (state, per-step exogenous input
:data:`EXO_FIELDS`, parameter vector); :func:`chunk_function` takes ``K``
steps (one output sample) and is compiled to C (:mod:`nniquad.sim.codegen`).
Two things keep the full model cheap: the vehicle dynamics are evaluated in
factored form (:func:`vehicle_dynamics`) and ``casadi.cse`` merges the sin/cos
that the separately generated pieces recompute.  The ``SX`` functions
(:func:`vehicle_dynamics`, :func:`rhs_function`, :func:`output_function`,
:func:`step_function`) are kept between processes by :mod:`nniquad.codecache`:
a new process loads them instead of deriving them from sympy again.
"""

from __future__ import annotations

from functools import lru_cache

import casadi as ca

from nniquad.codecache import cached_casadi_function
from nniquad.control import inner_loops as IL
from nniquad.laws.base import ControlLaw
from nniquad.laws.registry import law_named
from nniquad.model.numeric import (
    PARAM_NAMES,
    casadi_function,
    mixer_function,
    reaction_torque_function,
    rotation_function,
)
from nniquad.sim.codegen import compile_function
from nniquad.sim.options import check_model
from nniquad.sim.params import EXO_FIELDS, check_controller, param_layout, state_names

__all__ = ["vehicle_dynamics", "rhs_function", "output_function", "step_function", "chunk_function"]


@cached_casadi_function
def vehicle_dynamics() -> ca.Function:
    """The ``"exact"`` 12-state model, ``f(x, u, Omega_r, p) -> xdot``, in factored form for speed.

    :func:`nniquad.model.numeric.dynamics_function` ``("exact")`` inverts the rotational
    inertia matrix ``M(η) = Wᵀ J W`` symbolically (about 1570 operations).  Here the
    *same* sympy expressions -- translational accelerations, ``M(η)``, the
    Coriolis matrix ``C(η, η')``, ``W(η)`` and the gyroscopic torque of
    :mod:`nniquad.model.symbolic` -- are exported to CasADi and the Euler-Lagrange
    equations ``M η'' = Wᵀ τ_B - C η'`` are solved numerically (3x3), about
    620 operations.  The tests check it against ``dynamics_function("exact")``
    to round-off.
    """
    import sympy as sp
    from nniquad.model import symbolic as S  # lazily: sympy costs 0.3 s, and a cached build needs none


    s = S.symbols()
    W = S.euler_rate_matrix()
    tau_B = sp.Matrix(s.tau) + S.gyroscopic_torque()
    rhs = W.T * tau_B - S.coriolis_matrix("exact") * sp.Matrix(s.eta_dot)
    inputs = {"x": s.state, "u": (s.u1,) + s.tau, "Omega_r": (s.Omega_r,), "p": s.params}
    parts = casadi_function(
        "parts", inputs, {"acc": S.translational_dynamics("ned"), "M": S.rotational_inertia_matrix("exact"), "rhs": rhs}
    )
    x, u, om, p = ca.SX.sym("x", 12), ca.SX.sym("u", 4), ca.SX.sym("Omega_r"), ca.SX.sym("p", len(PARAM_NAMES))
    acc, M, r = parts(x, u, om, p)
    eta_dd = ca.solve(M, r)
    xdot = ca.vertcat(x[1], acc[0], x[3], acc[1], x[5], acc[2], x[7], eta_dd[0], x[9], eta_dd[1], x[11], eta_dd[2])
    return ca.Function("quadrotor_exact_factored", [x, u, om, p], [xdot], ["x", "u", "Omega_r", "p"], ["xdot"])


#: Pairs of the exogenous input (:data:`EXO_FIELDS`) by what they are.
_EXO_PAIRS: dict[str, tuple[str, str]] = {"noise": ("noise_x", "noise_y"), "gust": ("gust_x", "gust_y"),
                                          "ref": ("ref_x", "ref_y"), "ref_v": ("ref_vx", "ref_vy"),
                                          "ff": ("ff_x", "ff_y")}


def _exo(e: ca.SX, pair: str) -> ca.SX:
    """The two entries of the exogenous input ``e`` named ``pair`` (:data:`_EXO_PAIRS`)."""
    return e[[EXO_FIELDS.index(n) for n in _EXO_PAIRS[pair]]]


def _law_parameters(law: ControlLaw, P: dict) -> dict:
    """The entries the law's expressions read (its gains by field name and ``m_hat``) from the parameter dict."""
    return {**{name: P[f"gains.{name}"] for name in law.gain_names}, "m_hat": P["nominal.m"]}


def _closed_loop(model: str, X: ca.SX, e: ca.SX, p: ca.SX, controller: str = "nni") -> tuple[ca.SX, ca.SX]:
    """Continuous closed-loop right-hand side and the output vector of one model and controller (SX)."""
    P = {f.name: p[i] for i, f in enumerate(param_layout(controller))}
    law = law_named(check_controller(controller))
    noise, gust, ref, ref_v, a_ff = (_exo(e, n) for n in ("noise", "gust", "ref", "ref_v", "ff"))
    wind = ca.vertcat(P["run.wind_x"], P["run.wind_y"]) + gust
    ix = _index(model, controller)
    pos, vel = X[[ix["x"], ix["y"]]], X[[ix["x_dot"], ix["y_dot"]]]
    held = X[[ix["held_x"], ix["held_y"]]]
    xc = [X[ix[n]] for n in law.sim_state_names]
    # the law acts on the error to the reference (held: the error latched at the sample)
    meas = ca.if_else(P["run.sample_hold"] > 0.5, held, pos + noise - ref)
    vel_err = vel - ref_v
    discrete = P["run.discrete"] > 0.5
    a_list, xc_rates = law.sim_rates(_law_parameters(law, P), [meas[0], meas[1]], [vel_err[0], vel_err[1]], xc,
                                     discrete, ca)
    # the feedforward joins before the tilt limit, so the limit still bounds the commanded tilt
    a_raw = ca.vertcat(*a_list) + a_ff
    limit = _tilt_limit(model, X, P, ix)
    a_h = a_raw if limit is None else IL.limit_norm(a_raw, limit)
    xc_rates = _with_anti_windup(law, P, xc_rates, a_raw - a_h)
    # discrete variant: the controller states are constant over the period and advanced by step_function
    zc_dot = ca.if_else(discrete, ca.SX.zeros(len(xc)), ca.vertcat(*xc_rates)) if xc else ca.SX.zeros(0)
    if model in ("linear", "reduced"):
        g = P["nominal.g"]
        acc = (P["nominal.m"] / P["plant.m"]) * a_h + wind / P["plant.m"]
        phi_d, theta_d, tilt = IL.tilt_setpoints(a_h, g, 0)
        Xdot = ca.vertcat(vel[0], acc[0], vel[1], acc[1], zc_dot, ca.SX.zeros(2))
        return Xdot, ca.vertcat(a_h, tilt, phi_d, theta_d)

    # ---- full vehicle
    s = X[0:12]
    z = s[4]
    eta, eta_dot = s[[6, 8, 10]], s[[7, 9, 11]]
    w_state = X[[ix[f"w{i}"] for i in range(1, 5)]]
    g_z = _vertical_specific_force(X, P, ix)
    phi_d, theta_d, tilt = IL.tilt_setpoints(a_h, g_z, eta[2])
    cos_tilt = ca.cos(eta[0]) * ca.cos(eta[1])
    u1 = IL.collective_thrust(P["nominal.m"], g_z, cos_tilt)
    _, W = rotation_function()(eta)
    rates = ca.mtimes(W, eta_dot)  # gyro: body rates
    J_nom = ca.vertcat(P["nominal.Jx"], P["nominal.Jy"], P["nominal.Jz"])
    tau = IL.attitude_torques(eta, rates, phi_d, theta_d, J_nom, P["inner.attitude_wn_rad_s"], P["inner.attitude_zeta"],
                              P["inner.yaw_wn_rad_s"], P["inner.yaw_zeta"], P["inner.attitude_gain_scale"], P["inner.attitude_accel_limit_rad_s2"])
    p_nom = ca.vertcat(*[P[f"nominal.{name}"] for name in PARAM_NAMES])
    w_cmd, _ = IL.allocate(u1, tau, p_nom, P["plant.omega_max"])
    lag = P["run.motor_lag"] > 0.5
    w_act = ca.if_else(lag, ca.fmin(ca.fmax(w_state, 0), P["plant.omega_max"]), w_cmd)
    w_dot = ca.if_else(lag, (w_cmd - w_state) / P["plant.tau_motor"], ca.SX.zeros(4))
    p_true = ca.vertcat(*[P[f"plant.{name}"] for name in PARAM_NAMES])
    u, omega_r = mixer_function()(w_act, p_true)
    # rotor spin-up reaction torque -Jr dOmega_r/dt about z_B, exported from the symbolic model
    # (nniquad.model.symbolic.rotor_reaction_torque); zero without lag (w_dot = 0)
    u = u + ca.vertcat(0, reaction_torque_function()(w_dot, p_true))
    sdot = vehicle_dynamics()(s, u, omega_r, p_true)
    sdot[1] += wind[0] / P["plant.m"]
    sdot[3] += wind[1] / P["plant.m"]
    Xdot = ca.vertcat(sdot, zc_dot, ca.SX.zeros(2), z, w_dot)
    # the commanded rotor speeds too: the noise budget counts the steps a command sits at a limit
    return Xdot, ca.vertcat(a_h, tilt, w_act, u[0], w_cmd)


def _vertical_specific_force(X: ca.SX, P: dict, ix: dict[str, int]) -> ca.SX:
    """``g_z`` of the full model's altitude loop (:func:`nniquad.control.inner_loops.vertical_specific_force`)."""
    a_z = IL.altitude_command(X[ix["z"]], X[ix["z_dot"]], X[ix["z_int"]], P["inner.altitude_wn_rad_s"])
    return IL.vertical_specific_force(P["nominal.g"], a_z)


def _tilt_limit(model: str, X: ca.SX, P: dict, ix: dict[str, int]) -> ca.SX | None:
    """The norm limit of the horizontal command, ``g_z tan(T_lim)`` (``g`` on ``reduced``); ``None`` on ``linear``."""
    if model == "linear":
        return None
    g_z = P["nominal.g"] if model == "reduced" else _vertical_specific_force(X, P, ix)
    return g_z * ca.tan(P["run.tilt_limit"])


def _with_anti_windup(law: ControlLaw, P: dict, rates: list, excess: ca.SX, scale: ca.SX = 1.0) -> list:
    """``rates`` plus ``scale`` times the law's anti-windup gains times each axis's excess ``a_h - sat(a_h)``
    (:meth:`~nniquad.laws.base.ControlLaw.anti_windup_gains`; unchanged for a law without anti-windup)."""
    p = _law_parameters(law, P)
    out = list(rates)
    for a in (0, 1):
        gains = law.anti_windup_gains(p, a)
        for i, k in enumerate(gains or ()):
            if not (isinstance(k, (int, float)) and k == 0):
                out[2 * i + a] = out[2 * i + a] + scale * k * excess[a]
    return out


@lru_cache(maxsize=None)
def _index(model: str, controller: str) -> dict[str, int]:
    """Position of every state of a model with a controller law (:func:`nniquad.sim.params.state_names`)."""
    return {n: i for i, n in enumerate(state_names(check_model(model), controller))}


def _symbols(model: str, controller: str) -> tuple[ca.SX, ca.SX, ca.SX]:
    nx = len(state_names(check_model(model), controller))
    return ca.SX.sym("x", nx), ca.SX.sym("e", len(EXO_FIELDS)), ca.SX.sym("p", len(param_layout(controller)))


def _suffix(controller: str) -> str:
    """Function-name suffix: ``_<law>``."""
    return f"_{check_controller(controller)}"


def _held_excess(model: str, X: ca.SX, e: ca.SX, P: dict, law: ControlLaw) -> ca.SX:
    """The excess ``a_h - sat(a_h)`` of the command of the held measurement and the present controller state."""
    ix = _index(model, law.name)
    limit = _tilt_limit(model, X, P, ix)
    if limit is None or not any(law.anti_windup_gains(_law_parameters(law, P), a) for a in (0, 1)):
        return ca.SX.zeros(2)
    held = [X[ix["held_x"]], X[ix["held_y"]]]
    vel = X[[ix["x_dot"], ix["y_dot"]]] - _exo(e, "ref_v")
    a_list, _ = law.sim_rates(_law_parameters(law, P), held, [vel[0], vel[1]], [X[ix[n]] for n in law.sim_state_names],
                              True, ca)
    a_raw = ca.vertcat(*a_list) + _exo(e, "ff")
    return a_raw - IL.limit_norm(a_raw, limit)


@cached_casadi_function
def rhs_function(model: str, controller: str = "nni") -> ca.Function:
    """Continuous closed loop ``f(x, e, p) -> xdot`` (held measurement and exogenous input constant).

    With ``sample_hold = 0`` and zero noise this is an ordinary ODE, which the
    tests integrate with :func:`scipy.integrate.solve_ivp` as an independent check.
    """
    X, e, p = _symbols(model, controller)
    Xdot, _ = _closed_loop(model, X, e, p, controller)
    # ca.cse merges the sin/cos of the same angles computed by the separately generated pieces
    return ca.Function(f"rhs_{model}{_suffix(controller)}", [X, e, p], [ca.cse(Xdot)], ["x", "e", "p"], ["xdot"])


@cached_casadi_function
def output_function(model: str, controller: str = "nni") -> ca.Function:
    """``out(x, e, p) -> y`` (:data:`OUTPUT_NAMES`): commanded acceleration and tilt, rotor speeds, ..."""
    X, e, p = _symbols(model, controller)
    _, y = _closed_loop(model, X, e, p, controller)
    return ca.Function(f"out_{model}{_suffix(controller)}", [X, e, p], [ca.cse(y)], ["x", "e", "p"], ["y"])




@cached_casadi_function
def step_function(model: str, controller: str = "nni", delay_samples: int = 0) -> ca.Function:
    """One RK4 step ``step(x, e, p) -> x_next`` of length ``p[dt]``.

    At the start of the step a sample flag ``e[2] >= 1`` latches the measured error
    ``ξ + n - ξ_d`` into the held states; the step then integrates with it constant.
    With the discrete controller (``run.discrete = 1``) a later sample
    (``e[2] = 2``) first advances the controller state by one period on the
    value held over the period that ends, and then latches ``ξ_{k+1}``; the
    first sample (``e[2] = 1``, ``t = 0``) only latches.  The advance is the law's
    :meth:`~nniquad.laws.base.ControlLaw.sim_sample`: the exact ZOH equivalent of its
    continuous state equation (NNI ``z_{k+1} = e^{-ΓδT} z_k + (1 - e^{-ΓδT})/δ ξ_k``,
    what :class:`nniquad.control.discrete.DiscreteLaw` runs); the PD law with the
    true velocity latches the velocity with the position instead (a sampled
    velocity sensor).

    With a measurement delay of ``N = delay_samples`` samples the state ends with a delay line of ``N``
    samples per axis (:func:`nniquad.sim.params.delay_state_names`, constant between samples): a sample
    latches ``held ← d_N``, ``d_j ← d_{j-1}``, ``d_1 ← ξ + n - ξ_d``, so the law acts on the measurement
    taken ``N`` periods earlier (the velocity of ``pd_velocity`` is not delayed).
    """
    nd = 2 * int(delay_samples)
    X, e, p = _symbols(model, controller)
    if nd:  # the delay line trails the state: the step of the rest is the one without delay
        X = ca.SX.sym("x", X.numel() + nd)
    ix = _index(model, controller)
    hs = [ix["held_x"], ix["held_y"]]
    law = law_named(check_controller(controller))
    zs = [ix[n] for n in law.sim_state_names]
    pos = X[[ix["x"], ix["y"]]]
    P = {f.name: p[i] for i, f in enumerate(param_layout(check_controller(controller)))}
    discrete = P["run.discrete"] > 0.5
    advance = ca.logic_and(e[2] > 1.5, discrete)  # a later sample: the period that ends is integrated first
    sample = ca.logic_and(e[2] > 0.5, discrete)
    Xa = X
    if zs:
        vel_err = X[[ix["x_dot"], ix["y_dot"]]] - _exo(e, "ref_v")
        zc = law.sim_sample(_law_parameters(law, P), [X[i] for i in zs], [X[hs[0]], X[hs[1]]],
                            [vel_err[0], vel_err[1]], P["run.sample_period"], sample, advance, ca)
        # anti-windup over the period that ends: its excess, recomputed from the state and measurement held over it
        # (exact on reduced without a changing feedforward; full: g_z and a_ff read now, one period late)
        zc = ca.vertcat(*_with_anti_windup(law, P, zc, _held_excess(model, X, e, P, law),
                                           ca.if_else(advance, P["run.sample_period"], 0.0)))
        # the controller states and the held measurement are contiguous runs of the state (state_names)
        Xa = ca.vertcat(X[: zs[0]], zc, X[zs[-1] + 1 :])
    # the latch takes the error to the reference sampled with the measurement (through the delay line, if any)
    new = pos + _exo(e, "noise") - _exo(e, "ref")
    nb = X.numel() - nd
    line = [Xa[nb + 2 * j : nb + 2 * j + 2] for j in range(nd // 2)]
    latch = e[2] > 0.5
    Xs = ca.vertcat(Xa[: hs[0]], ca.if_else(latch, line[-1] if line else new, Xa[hs]), Xa[hs[-1] + 1 : nb],
                    *[ca.if_else(latch, ([new] + line)[j], line[j]) for j in range(len(line))])
    f = rhs_function(model, controller)
    if nd:
        f = _frozen_tail(f, nd)
    h = p[[entry.name for entry in param_layout(controller)].index("run.dt")]
    k1 = f(Xs, e, p)
    k2 = f(Xs + h / 2 * k1, e, p)
    k3 = f(Xs + h / 2 * k2, e, p)
    k4 = f(Xs + h * k3, e, p)
    Xn = Xs + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    name = f"step_{model}{_suffix(controller)}" + (f"_delay{nd // 2}" if nd else "")
    return ca.Function(name, [X, e, p], [ca.cse(Xn)], ["x", "e", "p"], ["x_next"])


def _frozen_tail(f: ca.Function, n: int) -> ca.Function:
    """``f(x, e, p)`` on a state with ``n`` more entries at its end, whose rate is zero (the delay line)."""
    X = ca.SX.sym("x", f.size1_in(0) + n)
    e, p = ca.SX.sym("e", f.size1_in(1)), ca.SX.sym("p", f.size1_in(2))
    return ca.Function(f"{f.name()}_tail{n}", [X, e, p], [ca.vertcat(f(X[: -n], e, p), ca.SX.zeros(n))])


@lru_cache(maxsize=None)
def chunk_function(model: str, K: int, controller: str = "nni", delay_samples: int = 0) -> ca.Function:
    """``K`` steps: ``chunk(x, E[n_exo x K], p) -> (x_K, y_K)`` (:data:`EXO_FIELDS`), compiled when possible.

    ``delay_samples``: the measurement delay line's length (:func:`step_function`).
    """
    step = step_function(model, controller, delay_samples)
    # MX around the SX step keeps the K steps a loop in the generated C (step emitted once):
    # the same speed as unrolled SX, a tenth of the compile time.
    nb = len(state_names(model, controller))
    X = ca.MX.sym("x", len(state_names(model, controller, delay_samples)))
    p = ca.MX.sym("p", len(param_layout(controller)))
    E = ca.MX.sym("E", len(EXO_FIELDS), K)
    if K == 1:
        xK = step(X, E, p)
    else:
        xs = step.mapaccum("steps", K)(X, E, ca.repmat(p, 1, K))
        xK = xs[:, -1]
    y = output_function(model, controller)(xK[:nb], E[:, -1], p)
    tag = f"_delay{delay_samples}" if delay_samples else ""
    fn = ca.Function(f"nniquad_chunk_{model}{_suffix(controller)}{tag}_{K}", [X, E, p], [xK, y], ["x", "E", "p"],
                     ["x_K", "y_K"])
    return compile_function(fn)
