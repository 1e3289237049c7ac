"""nniquad.jobs."""
