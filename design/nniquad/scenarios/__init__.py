"""nniquad.scenarios."""
