"""Batches: many surfaces meshed in parallel on a Dask cluster, each job isolated.

:func:`mesh_many` runs a list of :class:`Job` on a local cluster or on the
cluster of a ``distributed.Client``, and returns a :class:`JobResult` per job;
``rdmesh batch JOBS.jsonl --out DIR`` does the same from a file of jobs, with a
manifest that lets a second run resume. Dask is an optional dependency
(``pip install 'rdmesh[dask]'``), imported only when a batch runs.

Modules: :mod:`.job` (the job and its result), :mod:`.transport` (pickling
surfaces for the workers), :mod:`.worker` (what a worker runs),
:mod:`.runner` (the client side), :mod:`.bar` (the progress bar),
:mod:`.jobfile` (JSONL job files) and :mod:`.manifest` (the record of a run).
"""

from .job import Job, JobResult
from .runner import mesh_many

__all__ = ["Job", "JobResult", "mesh_many"]
