"""Test code run in a child Python process: a hang then fails its test at the
timeout, and a crash (SIGFPE, an abort) is a return code, not the run's end."""

from __future__ import annotations

import subprocess
import sys


def run_python(code: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``code`` with ``python -c`` in a new interpreter; its output as text."""
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout
    )
