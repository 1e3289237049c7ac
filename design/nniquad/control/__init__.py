"""nniquad.control."""
