"""A progress bar on stderr for meshing runs (tqdm), fed by the per-round callback.

The bar stays hidden for the first ``delay`` seconds, so short runs print
nothing. A small background thread draws it; the refinement thread only hands
over the latest round's numbers, so a Ctrl-C in the refinement thread never
lands inside a half-drawn bar. While the bar is open, log records sent to
stderr/stdout handlers of the root logger are written above it.
"""

from __future__ import annotations

import logging
import sys
import threading
from contextlib import ExitStack
from typing import IO, Any

log = logging.getLogger("rdmesh")


class ProgressBar:
    """Shows vertices, rounds and the current stage of a meshing run.

    Use as a context manager and pass :meth:`update` as the ``progress``
    callable of :func:`rdmesh.mesh_surface`::

        with ProgressBar(total=max_vertices) as bar:
            mesh = rdmesh.mesh_surface(surface, progress=bar.update)

    Parameters
    ----------
    total : int, optional
        The vertex budget, if any: the bar then shows a percentage.
    delay : float, default 1.0
        Seconds before the bar first appears.
    file : text stream, default sys.stderr
    disable : bool, default False
        Show nothing (``update`` still accepts calls).
    interval : float, optional
        Seconds between redraws while a round runs, so that the elapsed time
        keeps ticking: 0.5 on a terminal, 10 otherwise (a log file gets a
        line per round, not four a second). Each round is drawn at once.
    """

    def __init__(
        self,
        total: int | None = None,
        *,
        delay: float = 1.0,
        file: IO[str] | None = None,
        disable: bool = False,
        interval: float | None = None,
    ) -> None:
        self.total = total
        self.delay = float(delay)
        self.file = file
        self.disable = disable
        self.interval = interval
        self.shown = False
        self._latest: dict[str, Any] | None = None
        self._drawn: dict[str, Any] | None = None
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar = None
        self._stack = ExitStack()

    def __enter__(self) -> ProgressBar:
        if self.disable:
            return self
        from tqdm import tqdm
        from tqdm.contrib.logging import logging_redirect_tqdm

        file = self.file if self.file is not None else sys.stderr
        if self.interval is None:
            isatty = getattr(file, "isatty", None)
            self.interval = 0.5 if isatty is not None and isatty() else 10.0
        counter = "{n_fmt}/{total_fmt}{unit}" if self.total else "{n_fmt}{unit}"
        bar = "{percentage:3.0f}%|{bar}| " if self.total else ""
        self._bar = tqdm(
            total=self.total,
            desc="rdmesh",
            unit=" vertices",
            file=file,
            delay=self.delay,
            leave=True,
            dynamic_ncols=True,
            bar_format="{desc}: " + bar + counter + " [{elapsed}{postfix}]",
            postfix={"stage": "seeding"},
        )
        self._stack.enter_context(logging_redirect_tqdm())
        self._thread = threading.Thread(target=self._run, name="rdmesh-progress", daemon=True)
        self._thread.start()
        return self

    def update(self, info: dict) -> None:
        """Take one round's numbers: ``round``, ``stage``, ``vertices`` (and more)."""
        self._latest = dict(info)
        self._wake.set()

    # -- drawing (background thread) ----------------------------------------

    def _run(self) -> None:
        while not self._stop.is_set():
            self._wake.wait(self.interval)
            self._wake.clear()
            if self._stop.is_set():
                break
            self._draw()

    def _draw(self) -> None:
        bar = self._bar
        if bar is None:
            return
        latest = self._latest
        if latest is not None and latest is not self._drawn:
            self._drawn = latest
            bar.n = int(latest.get("vertices", bar.n))
            bar.set_postfix(
                {"round": latest.get("round"), "stage": latest.get("stage")}, refresh=False
            )
        if bar._time() - bar.start_t >= self.delay:
            bar.refresh()
            # tqdm's own bookkeeping: close() draws the final state and ends the
            # line only if it knows the bar has been shown.
            bar.last_print_t = bar._time()
            bar.last_print_n = bar.n
            self.shown = True

    def __exit__(self, *exc) -> None:
        if self._bar is None:
            return
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        try:
            if self.shown:
                self._draw()  # the last numbers, then close() ends the line
            self._bar.close()
        finally:
            self._stack.close()
            self._bar = None
