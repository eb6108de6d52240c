"""A progress bar on stderr for meshing runs (tqdm), fed by the per-round callback.

The bar stays hidden for the first ``delay`` seconds, so short runs print
nothing. A background thread draws it; the refinement thread only hands over
each round's numbers. All drawing goes through one lock taken with ``with``
(tqdm's own lock is not used: tqdm does not release it when a Ctrl-C lands
mid-draw). While the bar is shown, records of the console handlers of the
root and ``rdmesh`` loggers are written above it instead of through it.
"""

from __future__ import annotations

import logging
import sys
import threading
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
        line per round, not two a second). Each round is drawn at once.
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
        #: True once the bar has been drawn.
        self.shown = False
        self._latest: dict[str, Any] | None = None
        self._drawn: dict[str, Any] | None = None
        self._io = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar = None
        self._swapped: list[tuple[logging.Logger, int, logging.Handler]] = []

    def __enter__(self) -> ProgressBar:
        file = self.file if self.file is not None else sys.stderr
        if self.disable or file is None:  # no stderr (pythonw): nowhere to draw
            return self
        from tqdm import tqdm

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
        self._redirect_logging(file)
        self._thread = threading.Thread(target=self._run, name="rdmesh-progress", daemon=True)
        self._thread.start()
        return self

    def update(self, info: dict) -> None:
        """Take one round's numbers: ``round``, ``stage``, ``vertices`` (and more)."""
        self._latest = dict(info)
        self._wake.set()

    def __exit__(self, *exc) -> None:
        if self._bar is None:
            return
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        try:
            with self._io:
                self._take_latest()
                self._bar.close()  # draws and ends the line only if the bar was shown
        finally:
            self._restore_logging()
            self._bar = None

    # -- drawing (background thread) ----------------------------------------

    def _run(self) -> None:
        bar = self._bar
        while not self._stop.is_set():
            timeout = self.interval
            if not self.shown:
                # Wake up when the delay is over, to show the bar on time.
                left = self.delay - (bar._time() - bar.start_t)
                timeout = min(timeout, max(left, 0.0) + 0.01)
            self._wake.wait(timeout)
            self._wake.clear()
            if self._stop.is_set():
                break
            with self._io:
                self._take_latest()
                if bar._time() - bar.start_t >= self.delay:
                    self._refresh()

    def _take_latest(self) -> None:
        latest = self._latest
        if latest is None or latest is self._drawn:
            return
        self._drawn = latest
        bar = self._bar
        bar.n = int(latest.get("vertices", bar.n))
        bar.set_postfix(
            {"round": latest.get("round"), "stage": latest.get("stage")}, refresh=False
        )

    def _refresh(self) -> None:
        """Draw the bar; the caller holds ``self._io``."""
        bar = self._bar
        bar.refresh(nolock=True)
        # tqdm's bookkeeping: close() draws the final state and ends the line
        # only if it knows that the bar has been shown.
        bar.last_print_t = bar._time()
        bar.last_print_n = bar.n
        self.shown = True

    # -- log records above the bar --------------------------------------------------

    def _redirect_logging(self, file) -> None:
        streams = {sys.stderr, sys.stdout, file}
        for logger in (logging.getLogger(), log):
            for i, h in enumerate(logger.handlers):
                if isinstance(h, logging.StreamHandler) and h.stream in streams:
                    logger.handlers[i] = _AboveBar(self, h)
                    self._swapped.append((logger, i, h))

    def _restore_logging(self) -> None:
        for logger, i, h in self._swapped:
            if i < len(logger.handlers) and isinstance(logger.handlers[i], _AboveBar):
                logger.handlers[i] = h
        self._swapped.clear()


class _AboveBar(logging.Handler):
    """Wraps a console handler: clears the bar, emits, draws the bar again."""

    def __init__(self, bar: ProgressBar, inner: logging.Handler) -> None:
        super().__init__(inner.level)
        self.bar = bar
        self.inner = inner

    def emit(self, record: logging.LogRecord) -> None:
        pb = self.bar
        with pb._io:
            shown = pb.shown and pb._bar is not None
            if shown:
                pb._bar.clear(nolock=True)
            self.inner.handle(record)
            if shown:
                pb._refresh()
