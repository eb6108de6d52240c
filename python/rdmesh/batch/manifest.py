"""The manifest of ``rdmesh batch``: ``DIR/manifest.jsonl``, one record per ended job.

Records are appended as jobs end, each flushed and synced to disk, so a batch
that crashes (or is interrupted) loses at most the jobs that were running. A
second run reads the manifest and skips the jobs it holds as done: the last
record of the job's name is "ok" (or "stopped", unless those are retried),
with the same job digest (the line and its input file unchanged) and its
output file still there. Failed jobs always run again. A file lock keeps two
runs out of the same folder.
"""

from __future__ import annotations

import datetime
import fcntl
import json
import logging
import os
from typing import IO, Any

from .. import __version__
from .job import JobResult
from .jobfile import JobLine

log = logging.getLogger("rdmesh")

#: The manifest's file name in the output folder.
MANIFEST = "manifest.jsonl"
#: The lock file that keeps two runs out of one folder.
LOCK = ".rdmesh-batch.lock"


class FolderBusy(RuntimeError):
    """Another ``rdmesh batch`` run holds the output folder."""


class Manifest:
    """The manifest of the output folder ``folder``, locked while open.

    Use as a context manager::

        with Manifest("out") as manifest:
            done = manifest.done(job_line)
            manifest.append(record(result, job_line, "out"))

    Raises
    ------
    FolderBusy
        (on entry) another run holds the folder.
    OSError
        The folder or the manifest cannot be created or read.
    """

    def __init__(self, folder: str | os.PathLike) -> None:
        self.folder = os.fspath(folder)
        self.path = os.path.join(self.folder, MANIFEST)
        self.records: dict[str, dict[str, Any]] = {}
        self._lock: IO[str] | None = None

    def __enter__(self) -> Manifest:
        os.makedirs(self.folder, exist_ok=True)
        lock = open(os.path.join(self.folder, LOCK), "a")  # noqa: SIM115 - held until exit
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            raise FolderBusy(
                f"another rdmesh batch is writing to {self.folder!r}; wait for it or use "
                "another --out folder"
            ) from None
        self._lock = lock
        self.records = self.read()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._lock is not None:
            fcntl.flock(self._lock, fcntl.LOCK_UN)
            self._lock.close()
            self._lock = None

    def read(self) -> dict[str, dict[str, Any]]:
        """The last record of each job name; lines that do not parse (a record cut
        short by a crash) are skipped with a warning."""
        records: dict[str, dict[str, Any]] = {}
        if not os.path.exists(self.path):
            return records
        with open(self.path, encoding="utf-8") as lines:
            for number, text in enumerate(lines, start=1):
                if not text.strip():
                    continue
                try:
                    rec = json.loads(text)
                    name = rec["name"]
                except (json.JSONDecodeError, TypeError, KeyError):
                    log.warning("%s:%d: not a manifest record; ignored", self.path, number)
                    continue
                records[name] = rec
        return records

    def done(self, job: JobLine, retry_stopped: bool = False) -> bool:
        """True if the manifest holds ``job`` as done, with its output in place."""
        rec = self.records.get(job.name)
        if rec is None or rec.get("job") != job.digest:
            return False
        statuses = ("ok",) if retry_stopped else ("ok", "stopped")
        if rec.get("status") not in statuses or not rec.get("output"):
            return False
        return os.path.isfile(os.path.join(self.folder, rec["output"]))

    def append(self, rec: dict[str, Any]) -> None:
        """Add one record at the end, on disk before this returns."""
        line = json.dumps(rec, allow_nan=False, default=_plain) + "\n"
        with open(self.path, "a", encoding="utf-8") as out:
            out.write(line)
            out.flush()
            os.fsync(out.fileno())
        self.records[rec["name"]] = rec


def record(result: JobResult, job: JobLine, folder: str) -> dict[str, Any]:
    """The manifest record of one ended job.

    Fields: ``name``, ``status``, ``error``, ``output`` (the mesh file,
    relative to the folder; null when none was written), ``vertices``,
    ``faces``, ``seconds``, ``topology`` (components, Euler characteristic
    and genus per component, closed manifold, smallest angle, whether the
    topological-ball tests held and whether that is certified), ``job`` (the
    line's digest), ``line``, ``worker``, ``finished`` (UTC) and ``rdmesh``
    (the version).
    """
    output = None
    if result.output is not None:
        output = os.path.relpath(result.output, folder)
    topo = dict(result.topology)
    return {
        "name": job.name,
        "status": result.status,
        "error": result.error,
        "output": output,
        "vertices": topo.pop("vertices", None),
        "faces": topo.pop("faces", None),
        "seconds": round(result.seconds, 3),
        "topology": topo or None,
        "job": job.digest,
        "line": job.line,
        "worker": result.worker,
        "finished": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "rdmesh": __version__,
    }


def _plain(value: Any) -> Any:
    """numpy scalars and the like, for json.dumps."""
    if hasattr(value, "item"):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")
