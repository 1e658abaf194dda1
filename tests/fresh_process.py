"""Run a check's catch in a fresh Python process: module switches the engines' kernels read when they compile
(``wp.constant``, ``ti.static``) take effect only there."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

TESTS = str(Path(__file__).resolve().parent)


def last_line(code: str, timeout: float = 600.0) -> str:
    """The last line ``code`` prints, run by this interpreter with ``tests/`` on its path; asserts it exits 0."""
    out = subprocess.run([sys.executable, "-c", f"import sys\nsys.path.insert(0, {TESTS!r})\n{code}"],
                         capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()[-1]
