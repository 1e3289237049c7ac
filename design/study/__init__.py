"""nniquad.study."""
