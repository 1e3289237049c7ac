"""The sampled-data cascade certified over a box of parameters: robust Lyapunov LMI, grid check, region of attraction.

What is certified
-----------------
The linearised cascade of :mod:`nniquad.analysis.linearised_cascade` (the simulator's
CasADi Jacobians at hover: rigid body, altitude PID and yaw hold, attitude PD in
its linear region, allocation, first-order motor lag, NNI controller), sampled
as in :mod:`nniquad.analysis.sampled`: the position is sampled at ``rate_hz``
and held (exact ZOH), the NNI controller runs in discrete time (its exact ZOH
equivalent, variant ``"discrete"``, its output held over the period), the
attitude loop, the motors and the altitude loop are **continuous**.  All 19
states are kept (no reduction to the horizontal subsystem).

The parameter box
-----------------
:class:`ParameterBox` holds four intervals of factors on the vehicle's nominal
values.  At a parameter point the *true* vehicle has mass ``f_m m``, inertias
``f_Jx Jx, f_Jy Jy, f_Jz Jz`` (the **three inertia factors vary independently**
inside ``inertia_factor``, as the Monte Carlo draws them), motor time constant
``f_τ τ_m``, and the attitude torques are multiplied by ``f_a``
(:attr:`nniquad.control.inner_gains.InnerLoopGains.attitude_gain_scale` times
``f_a``).  The controller's nominal mass ``m̂`` and the inner loops' nominal
inertias stay nominal: they are what the flight code knows.  A point is thus
six numbers ``θ = (f_m, f_Jx, f_Jy, f_Jz, f_a, f_τ)`` (:data:`POINT_NAMES`);
the box has ``2^6 = 64`` vertices.

With ``m ≠ m̂`` hover is an equilibrium with the altitude integrator holding
``a_z = g (1 - m/m̂)`` (so that ``u1 = m̂ (g - a_z) = m g``) and the rotors at
``sqrt(m g / 4b)``; the residual ``|f(x_eq)|`` is checked at every point.

Decoupled subsystems
--------------------
After a fixed orthogonal change of the rotor coordinates (collective, roll
pair, pitch pair, yaw: :func:`mode_transform`) the loop at hover splits into
four blocks that do not feed each other (:data:`SUBSYSTEMS`: the x axis, the y
axis, the altitude loop, the yaw hold); :func:`coupling` measures what is left
(the ``O(ε²)`` error of the Jacobian, below :data:`COUPLING_TOL`).  Each block
depends on some of the six coordinates only (:func:`relevant_coordinates`:
the x axis on mass, Jy, attitude gain and motor; the y axis on Jx instead).

Certificates and what they cover
--------------------------------
* :func:`robust_lyapunov`, per block: ``P(θ) = P_0 + Σ θ_j P_j`` (``θ ∈ [-1, 1]``
  the block's log factors normalised on the box) with
  ``A_d(θ)ᵀ P(θ) A_d(θ) ⪯ ρ² P(θ)`` at the **LMI points** (a grid of
  :data:`LMI_POINTS_PER_AXIS` = 3 per coordinate: the vertices, the centre and
  the mid-faces) and ``I ⪯ P(θ)`` on the whole cube (affine: checked at its
  corners); decay ``-ln ρ / T``.  A common ``P`` was tried first: for the
  certified design no common ``P`` exists even for the two motor time
  constants 0.5 and 2 times nominal alone, so the Lyapunov matrix depends on
  the (constant, unknown) parameters, which is all a time-invariant
  uncertainty needs.  ``A_d(θ)`` is not affine in ``θ`` (matrix exponentials of
  Jacobians), so nothing is proved between the LMI points.
* :func:`grid_check`: the exact contraction factor ``‖P^{1/2} A_d(θ) P^{-1/2}‖₂``
  of the assembled 19-state ``P(θ)`` (:func:`assemble_P`, on the full coupled
  loop) and the spectral radius, with numpy, on a grid of
  :data:`nniquad.config.CASCADE_GRID_POINTS_PER_AXIS` points per coordinate
  in all six coordinates (4096 points; other points than the LMI points except
  the vertices).  The contraction is proven at every grid point, and between
  them cell by cell (:mod:`nniquad.analysis.cascade.box_proof`: the corners
  proven with a verified Cholesky test, the interpolation between them bounded
  by an estimated allowance; the section's ``box_proof`` states the cells).
* Region of attraction under the norm tilt limit ``‖a‖ <= u0``,
  ``u0 = (lowest mass factor) g tan(tilt)`` (the limit is ``g_z tan(tilt)`` with
  ``g_z = (m/m̂) g`` at hover): by default the linear-zone ellipsoid of the
  grid-checked ``P(θ)`` (:func:`linear_zone_reach`; the generalised sector
  condition with ``G = 0``), the smallest reach over the LMI and grid points.
  The horizontal blocks' ``P(θ)`` is re-solved for the widest such reach
  (:func:`reach_lyapunov`, at :data:`nniquad.config.CASCADE_REACH_DECAY_FRACTION`
  of the block's best decay) and kept when it reaches further and passes the
  grid check; the ellipsoid cannot reach beyond about ``u0 / kp`` (the command
  of a pure position offset).  A vehicle whose y block mirrors its x block
  reuses x's answers, re-checked with numpy on y's loops (:func:`mirror_blocks`).

Modules
-------
The code lives in :mod:`nniquad.analysis.cascade` (box, family, lyapunov, roa,
section, check); this module gathers its public names.
"""

from __future__ import annotations

from nniquad.analysis.cascade.box import BOX_KEYS, POINT_NAMES, ParameterBox, box_coordinates, tilt_accel_limit
from nniquad.analysis.cascade.family import (
    COUPLING_TOL,
    RELEVANCE_BAND,
    RELEVANCE_TOL,
    SUBSYSTEMS,
    CascadeFamily,
    coupling,
    mode_transform,
    relevance_consistent,
    relevant_coordinates,
    sampled_family,
)
from nniquad.analysis.cascade.lyapunov import (
    GridCheck,
    RobustLyapunov,
    WitnessMargins,
    checked_grid_size,
    contraction_batch,
    grid_check,
    point_index,
    reach_lyapunov,
    robust_lyapunov,
    witness_margins,
)
from nniquad.analysis.cascade.recheck import check_cascade_rows, check_cascade_section
from nniquad.analysis.cascade.region import linear_zone_reach
from nniquad.analysis.cascade.section import LMI_POINTS_PER_AXIS, BoxSearch, cascade_section, widest_box

__all__ = [
    "BOX_KEYS",
    "POINT_NAMES",
    "ParameterBox",
    "box_coordinates",
    "tilt_accel_limit",
    "CascadeFamily",
    "sampled_family",
    "SUBSYSTEMS",
    "COUPLING_TOL",
    "RELEVANCE_TOL",
    "RELEVANCE_BAND",
    "mode_transform",
    "coupling",
    "relevant_coordinates",
    "relevance_consistent",
    "contraction_batch",
    "checked_grid_size",
    "RobustLyapunov",
    "robust_lyapunov",
    "reach_lyapunov",
    "WitnessMargins",
    "witness_margins",
    "GridCheck",
    "grid_check",
    "point_index",
    "linear_zone_reach",
    "LMI_POINTS_PER_AXIS",
    "BoxSearch",
    "widest_box",
    "cascade_section",
    "check_cascade_section",
    "check_cascade_rows",
]
