"""Adapters that fly a certified law in other people's software.

Each module here takes a certificate (or its exported controller) and fits it to
one outside interface: a simulator's controller API or a flight stack's
controller hook.  They sit beside :mod:`nniquad.jobs`: they compose the layers
below and nothing below imports them.
"""
