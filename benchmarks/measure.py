# SPDX-License-Identifier: GPL-3.0-or-later
"""One command in a child process: wall time, peak RSS, output, timeout.

``run_measured(cmd, timeout)`` is how the suite runs every mesher; it uses
the standard library only.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

__all__ = ["last_line", "run_measured"]

# The command is started through this small launcher.  Linux carries the
# high-water RSS of the process that calls exec over into the new program's
# ru_maxrss (exec_mmap records the old mm's peak), so a child forked straight
# from the (large) suite process would report at least the suite's RSS.
# The launcher is a bare interpreter (-I -S, about 10 MB); since ru_maxrss is
# a maximum, not a sum, the grandchild's figure is exact once it exceeds that.
_LAUNCHER = r"""
import os, sys
pid = os.fork()
if pid == 0:
    try:
        limit = int(sys.argv[2])
        if limit > 0:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        os.execvp(sys.argv[3], sys.argv[3:])
    finally:
        os._exit(127)
_, status, usage = os.wait4(pid, 0)
with open(sys.argv[1], "w") as fh:
    fh.write("%d %d\n" % (os.waitstatus_to_exitcode(status), usage.ru_maxrss))
"""


def run_measured(
    cmd: list[str],
    timeout: float | None,
    env: dict[str, str] | None = None,
    memory_limit_mb: float | None = None,
) -> dict[str, Any]:
    """Run ``cmd`` in a new process group; wall time, peak RSS, output.

    ``memory_limit_mb`` caps the command's address space (RLIMIT_AS), so a
    run that would take the machine's memory fails instead (None: no cap).

    Returns ``returncode`` (None after a timeout), ``stdout``, ``stderr``,
    ``wall`` (seconds, launch to exit), ``peak_rss_mb`` (the command's maximum
    resident set size from ``wait4`` in a small launcher process, MiB; None
    if unknown) and ``timed_out``.  At the timeout the whole process group is
    killed.  KeyboardInterrupt kills it too, then propagates.
    """
    with (
        tempfile.TemporaryFile() as out,
        tempfile.TemporaryFile() as err,
        tempfile.TemporaryDirectory() as tmp,
    ):
        report = Path(tmp) / "rusage"
        limit = int(memory_limit_mb * 2**20) if memory_limit_mb else 0
        launcher = [sys.executable, "-I", "-S", "-c", _LAUNCHER, str(report), str(limit)]
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [*launcher, *cmd],
            stdout=out,
            stderr=err,
            stdin=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )
        timed_out = threading.Event()

        def kill() -> None:
            timed_out.set()
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)

        timer = threading.Timer(timeout, kill) if timeout else None
        if timer is not None:
            timer.daemon = True
            timer.start()
        try:
            proc.wait()
        except KeyboardInterrupt:
            kill()
            proc.wait()
            raise
        finally:
            if timer is not None:
                timer.cancel()
        wall = time.perf_counter() - t0
        returncode, rss = proc.returncode, None
        try:
            code, kib = report.read_text().split()
            returncode, rss = int(code), int(kib) / 1024.0  # Linux: KiB
        except (OSError, ValueError):
            pass
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode(errors="replace")
        stderr = err.read().decode(errors="replace")
    return {
        "returncode": None if timed_out.is_set() else returncode,
        "stdout": stdout,
        "stderr": stderr,
        "wall": wall,
        "peak_rss_mb": rss,
        "timed_out": timed_out.is_set(),
    }


def last_line(text: str) -> str:
    """The last non-blank line of ``text``, stripped ("" if there is none)."""
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else ""
