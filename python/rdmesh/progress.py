"""A progress bar on stderr for meshing runs: plain tqdm, fed by the per-round callback.

The bar stays hidden for the first ``delay`` seconds, so short runs print
nothing. While it is shown, log records go through ``tqdm.write`` (tqdm's own
``logging_redirect_tqdm``), so they appear above the bar instead of through it.

tqdm is an optional dependency (``pip install 'rdmesh[progress]'``): without
it a bar that should be shown raises ImportError saying so, and the CLI runs
without a bar.
"""

from __future__ import annotations

import importlib.util
import sys
import time
from contextlib import ExitStack
from typing import IO

#: What to install for a progress bar.
INSTALL_HINT = "pip install 'rdmesh[progress]' (or tqdm)"


def available() -> bool:
    """True when tqdm, which draws the bar, is installed."""
    try:
        return importlib.util.find_spec("tqdm") is not None
    except ValueError:  # tqdm in sys.modules as None (blocked) or without a spec
        return False


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
        Seconds before the bar first appears (at the first round after it).
    file : text stream, default sys.stderr
    disable : bool, default False
        Show nothing (``update`` still accepts calls).

    Raises
    ------
    ImportError
        On entering, unless disabled, when tqdm is not installed.
    """

    def __init__(
        self,
        total: int | None = None,
        *,
        delay: float = 1.0,
        file: IO[str] | None = None,
        disable: bool = False,
    ) -> None:
        self.total = total
        self.delay = float(delay)
        self.file = file
        self.disable = disable
        self._bar = None
        self._stack = ExitStack()

    def __enter__(self) -> ProgressBar:
        file = self.file if self.file is not None else sys.stderr
        if self.disable or file is None:  # no stderr (pythonw): nowhere to draw
            return self
        try:
            from tqdm import tqdm
            from tqdm.contrib.logging import logging_redirect_tqdm
        except ImportError as exc:
            raise ImportError(
                f"the progress bar (progress=True) needs tqdm: {INSTALL_HINT}", name="tqdm"
            ) from exc

        class Bar(tqdm):
            """Stays hidden for ``delay`` seconds even when a log record asks
            for a redraw, and remembers whether it was ever drawn."""

            drawn = False

            def display(self, *args, **kwargs):
                start = getattr(self, "start_t", None)  # unset while tqdm starts
                if (
                    not self.drawn
                    and self.delay > 0
                    and (start is None or time.time() - start < self.delay)
                ):
                    return None
                self.drawn = True
                return super().display(*args, **kwargs)

        counter = "{n_fmt}/{total_fmt}{unit}" if self.total else "{n_fmt}{unit}"
        bar = "{percentage:3.0f}%|{bar}| " if self.total else ""
        self._bar = self._stack.enter_context(
            Bar(
                total=self.total,
                desc="rdmesh",
                unit=" vertices",
                file=file,
                delay=self.delay,
                leave=True,
                dynamic_ncols=True,
                mininterval=0.0,
                bar_format="{desc}: " + bar + counter + " [{elapsed}{postfix}]",
                postfix={"stage": "seeding"},
            )
        )
        self._stack.enter_context(logging_redirect_tqdm(tqdm_class=Bar))
        return self

    def update(self, info: dict) -> None:
        """Take one round's numbers: ``round``, ``stage``, ``vertices`` (and more)."""
        bar = self._bar
        if bar is None:
            return
        bar.set_postfix({"round": info.get("round"), "stage": info.get("stage")}, refresh=False)
        bar.update(int(info.get("vertices", bar.n)) - bar.n)

    def __exit__(self, *exc) -> None:
        bar = self._bar
        if bar is not None and bar.drawn:
            # tqdm ends the line only if it noted a draw after the delay; a
            # Ctrl-C mid-draw, or a log record's redraw, draws without noting.
            bar.last_print_t = max(bar.last_print_t, bar.start_t + self.delay)
        self._stack.close()
        self._bar = None
