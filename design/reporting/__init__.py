"""nniquad.reporting."""
