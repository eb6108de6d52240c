"""The memory a run may still use, so that a runaway refinement stops with its
partial mesh (``BudgetExceeded``) before the system kills the process.

On Linux the figure is ``MemAvailable`` of ``/proc/meminfo`` (free memory plus
what the kernel can reclaim), or less where a cgroup (a container, a batch
job's slot) caps the process: its ``memory.max`` minus ``memory.current``.
Elsewhere nothing is known and the check is off.
"""

from __future__ import annotations

from pathlib import Path

#: Bytes per point a round inserts (the triangulation, the facet tables, the
#: snapshot's arrays): 1.6 KB per sample on the tanglecube at R/300, 3.2 KB on
#: the torus at R/400 (``benchmarks/memory_per_sample.py``: resident memory in
#: the last round over the samples).
BYTES_PER_VERTEX = 4096
#: ... and what the end of a run (the complex, the report) adds per sample:
#: 0.54 and 0.62 KB in those runs (peak over the last round), rounded up.
FINISH_BYTES_PER_VERTEX = 1024


def available_bytes() -> int | None:
    """Bytes this process may still allocate, or None where unknown."""
    figures = [_meminfo_available(), _cgroup_room()]
    known = [x for x in figures if x is not None]
    return min(known) if known else None


def shortfall(vertices: int, points: int) -> str | None:
    """Why a round inserting ``points`` into ``vertices`` samples would not fit
    in memory, with the run's end, or None when it fits (or nothing is known)."""
    room = available_bytes()
    if room is None:
        return None
    need = BYTES_PER_VERTEX * points + FINISH_BYTES_PER_VERTEX * (vertices + points)
    if need <= room:
        return None
    return (
        f"memory: a round of {points} points on {vertices} samples needs about "
        f"{need / 2**20:.0f} MB, and {room / 2**20:.0f} MB are available"
    )


def _meminfo_available() -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_room() -> int | None:
    base = Path("/sys/fs/cgroup")
    try:
        cap = (base / "memory.max").read_text().strip()
        if cap == "max":
            return None
        return int(cap) - int((base / "memory.current").read_text().strip())
    except (OSError, ValueError):
        return None
