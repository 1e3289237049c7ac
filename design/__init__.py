"""nniquad: velocity-free quadrotor position control by nonlinear negative-imaginary theory.

The package is the library of the design study: vehicle parameters, the symbolic
model and its numeric exports, the linear NI layer and its LMIs, simulation,
metrics, tuning and certificates.  Heavy dependencies (sympy, casadi, cvxpy) are
imported by the modules that need them, so importing :mod:`design` is cheap.
"""

__version__ = "0.1.0"
