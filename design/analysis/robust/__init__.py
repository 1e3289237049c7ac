"""The sampled-data cascade certified over a box of parameters, in focused modules.

:mod:`~nniquad.analysis.robust.box`
    The parameter box and its coordinates.
:mod:`~nniquad.analysis.robust.family`
    The sampled cascade at many parameter points, its decoupled subsystems and which coordinates reach them.
:mod:`~nniquad.analysis.robust.lyapunov`
    Each subsystem's parameter-dependent Lyapunov matrix, its rounding margins and the grid check.
:mod:`~nniquad.analysis.robust.roa`
    The region of attraction under the norm tilt limit (linear zone; Lur'e-Postnikov function).
:mod:`~nniquad.analysis.robust.section`
    The certificate's ``cascade`` section.
:mod:`~nniquad.analysis.robust.check`
    Its re-check from the design alone (``verify``).

:mod:`nniquad.analysis.robust_cascade` gathers the public names and states what is certified.
"""
