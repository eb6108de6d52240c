#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""Memory per sample of a run, for the memory stop's estimates
(``rdmesh.refine.memory``): the resident memory in the last refinement round
over the samples, and what the run's end adds (peak over the last round) per
output vertex. One surface per process (the peak is the process's)::

    python benchmarks/memory_per_sample.py torus 400
    python benchmarks/memory_per_sample.py tanglecube 300
"""

from __future__ import annotations

import resource
import sys

import rdmesh


def rss() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize()


def main(argv: list[str]) -> int:
    name, k = argv[0], float(argv[1])
    s = rdmesh.surfaces.get(name)
    base, last = rss(), {}

    def progress(d: dict) -> None:
        last["samples"], last["rss"] = d["vertices"], rss()

    m = rdmesh.mesh_surface(s, radius_bound=s.radius / k, progress=progress)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    n = len(m.vertices)
    print(
        f"{name} at R/{k:g}: {n} vertices; {(last['rss'] - base) / last['samples']:.0f} B per "
        f"sample in the last round ({last['samples']} samples); the end adds "
        f"{(peak - last['rss']) / n:.0f} B per vertex"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
