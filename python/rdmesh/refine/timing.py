"""Wall time per phase of a run, for ``SurfaceMesh.stats["phase_seconds"]``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager


class PhaseTimer:
    """Adds up the wall time spent in named phases.

    The main thread and the core's worker thread each time phases of their
    own, so no phase is added to from two threads.
    """

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    @contextmanager
    def __call__(self, phase: str) -> Iterator[None]:
        t = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[phase] = self.seconds.get(phase, 0.0) + time.perf_counter() - t
