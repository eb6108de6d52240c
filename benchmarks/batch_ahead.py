# SPDX-License-Identifier: GPL-3.0-or-later
"""A/B of how many jobs ``mesh_many`` keeps in flight per worker thread.

The good jobs of ``benchmarks/batch.py`` run once serially here, then on one
2-worker local cluster with ``AHEAD`` 0 (one job per worker) and 1 (the job
it runs and the next), alternating the order each repeat, so that both share
the machine's load::

    python benchmarks/batch_ahead.py [--repeats 2]

Prints, per run: wall time, its ratio to the serial time, the share of time
the workers were busy and the workers' CPU time; every mesh is checked
against its serial run.
"""

from __future__ import annotations

import argparse
import logging
import shutil
import tempfile
import time
from pathlib import Path

import batch as B


def main(argv: list[str] | None = None) -> int:
    import rdmesh
    from rdmesh.batch import runner

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeats", type=int, default=2)
    args = p.parse_args(argv)
    logging.getLogger("distributed").propagate = False
    work = Path(tempfile.mkdtemp(prefix="rdmesh-ahead-"))
    wrong = 0
    try:
        good = B.good_cases(work / "inputs", False)
        with runner._cluster(None, 2, "auto") as client:
            client.run(B._warm_up)
            t0, c0 = time.perf_counter(), time.process_time()
            hashes = B.serial(good)
            serial = time.perf_counter() - t0
            print(f"serial {serial:.2f} s, CPU {time.process_time() - c0:.1f} s", flush=True)
            for rep in range(args.repeats):
                for ahead in (0, 1) if rep % 2 == 0 else (1, 0):
                    runner.AHEAD = ahead
                    w0 = sum(client.run(B._cpu_seconds).values())
                    t0 = time.perf_counter()
                    res = rdmesh.mesh_many([B.as_job(c) for c in good], client=client)
                    wall = time.perf_counter() - t0
                    cpu = sum(client.run(B._cpu_seconds).values()) - w0
                    check = B.check(res, good, hashes)
                    wrong += len(check["wrong"])
                    busy = sum(r.seconds for r in res) / (2 * wall)
                    print(f"AHEAD={ahead}: {wall:.2f} s = {wall / serial:.3f} x serial, "
                          f"workers busy {busy:.1%}, workers' CPU {cpu:.1f} s, "
                          f"identical {check['identical']}/{len(good)}", flush=True)  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if wrong else 0


if __name__ == "__main__":
    raise SystemExit(main())
