"""One timer for every benchmark: the best wall time of a few repeats (the least disturbed by a noisy machine)."""

from __future__ import annotations

import time
from typing import Callable


def best_of(fn: Callable[[], object], repeat: int = 3, *, warmup: bool = False) -> float:
    """Smallest wall time [s] of ``repeat`` calls of ``fn`` (after one untimed call when ``warmup``)."""
    if warmup:
        fn()  # compile / import once, outside the timing
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best
