"""nniquad.tuning."""
