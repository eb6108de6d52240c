"""The tests' local Dask cluster: 2 worker processes, 1 thread each (what
``mesh_many`` starts by itself), quiet, with no dashboard."""

from __future__ import annotations

import logging


def local_cluster(allowed_failures: int | None = None):
    """A ``distributed.LocalCluster`` of 2 worker processes; with
    ``allowed_failures`` set, the scheduler's retry count for tasks whose
    worker died."""
    import dask
    import distributed

    config = {}
    if allowed_failures is not None:
        config["distributed.scheduler.allowed-failures"] = allowed_failures
    with dask.config.set(config):
        return distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            scheduler_kwargs={"dashboard": False},
            silence_logs=logging.CRITICAL,
        )
