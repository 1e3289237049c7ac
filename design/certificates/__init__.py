"""nniquad.certificates."""
