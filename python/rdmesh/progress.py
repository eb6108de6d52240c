"""A minimal progress bar on stderr (placeholder until the CLI work lands)."""

from __future__ import annotations

import sys


class ProgressBar:
    """Shows round, stage and vertex count on one stderr line."""

    def __enter__(self) -> ProgressBar:
        return self

    def update(self, info: dict) -> None:
        sys.stderr.write(
            f"\rrdmesh: round {info['round']:4d}  {info['stage']:8s} "
            f"{info['vertices']:9d} vertices  {info['seconds']:7.1f} s"
        )
        sys.stderr.flush()

    def __exit__(self, *exc) -> None:
        sys.stderr.write("\n")
