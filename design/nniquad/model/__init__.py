"""nniquad.model."""
