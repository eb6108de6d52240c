"""A progress bar over the jobs of a batch (tqdm, on stderr).

While it is shown, log records go through ``tqdm.write`` so that they appear
above the bar. It counts every job that ends, with the outcomes so far.
"""

from __future__ import annotations

import sys
from contextlib import ExitStack
from typing import IO, Any

from .job import STATUSES


class JobBar:
    """Counts ended jobs: ``with JobBar(total) as bar: ... bar.update(result)``.

    Parameters
    ----------
    total : int
        The number of jobs.
    initial : int, default 0
        Jobs already done before this run (a resumed batch).
    disable : bool, default False
        Show nothing (``update`` still counts).
    file : text stream, default sys.stderr
    """

    def __init__(
        self, total: int, *, initial: int = 0, disable: bool = False, file: IO[str] | None = None
    ) -> None:
        self.total = total
        self.initial = initial
        self.disable = disable
        self.file = file
        self.counts = dict.fromkeys(STATUSES, 0)
        self._bar: Any = None
        self._stack = ExitStack()

    def __enter__(self) -> JobBar:
        file = self.file if self.file is not None else sys.stderr
        if self.disable or file is None:
            return self
        from tqdm import tqdm
        from tqdm.contrib.logging import logging_redirect_tqdm

        self._bar = self._stack.enter_context(
            tqdm(
                total=self.total,
                initial=self.initial,
                desc="rdmesh batch",
                unit=" jobs",
                file=file,
                dynamic_ncols=True,
                leave=True,
            )
        )
        self._stack.enter_context(logging_redirect_tqdm())
        return self

    def update(self, result: Any) -> None:
        """Count one ended job (a :class:`JobResult`)."""
        self.counts[result.status] = self.counts.get(result.status, 0) + 1
        if self._bar is not None:
            self._bar.set_postfix(self.counts, refresh=False)
            self._bar.update(1)

    def __exit__(self, *exc: Any) -> None:
        self._stack.close()
        self._bar = None
