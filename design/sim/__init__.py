"""nniquad.sim."""
