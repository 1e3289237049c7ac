"""The sampled-data cascade certified over a box of parameters, in focused modules.

:mod:`~nniquad.analysis.cascade.box`
    The parameter box and its coordinates.
:mod:`~nniquad.analysis.cascade.family`
    The sampled cascade at many parameter points, its decoupled subsystems and which coordinates reach them.
:mod:`~nniquad.analysis.cascade.lyapunov`
    Each subsystem's parameter-dependent Lyapunov matrix, its rounding margins and the grid check.
:mod:`~nniquad.analysis.cascade.region`
    The region of attraction under the norm tilt limit (linear zone; Lur'e-Postnikov function).
:mod:`~nniquad.analysis.cascade.section`
    The certificate's ``cascade`` section.
:mod:`~nniquad.analysis.cascade.recheck`
    Its re-check from the design alone (``verify``).

:mod:`nniquad.analysis.cascade.box_certificate` gathers the public names and states what is certified.
"""
