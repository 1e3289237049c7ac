"""nniquad.analysis."""
