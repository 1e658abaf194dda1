"""The README's command lines, as a user types them from the clone's root (issue 55): found in its ``bash``
blocks and in the inline code of its text and tables, run in a temporary copy of the clone (its top-level
entries linked, so every file a line writes lands in the copy, and one written beside them is seen).

:func:`readme_lines` finds them; :func:`run_line` runs one through ``bash`` with the installed ``gasp``;
:func:`cut_frames` shortens a simulation for the default tier. What each line must show is in
``tests/test_readme.py`` (``CHECKS``), keyed by the line.
"""
from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

#: Steps of a line that are not run, and why (by how the step starts).
NOT_RUN = {
    "python -m venv": "creates the virtual environment the test already runs in",
    ". .venv/bin/activate": "activates the virtual environment the test already runs in",
    "python -m pip install": "installs packages from the network into this environment; tests/test_install_lines.py "
                             "checks the extras and folders it names",
    "pip install": "installs packages from the network",
    "apt-get": "installs system packages as root",
    "npm install": "installs Node.js tools from the network",
    "python -m pytest": "the test suite itself (.ci/run runs it; tests/test_readme.py checks the line against it)",
}


@dataclass
class Line:
    """One command line of the README: ``text`` as written, its ``&&`` steps, its ``# comment`` (bash blocks)."""

    text: str
    steps: list[str]
    comment: str = ""

    def runnable(self) -> list[str]:
        return [s for s in self.steps if not why_not_run(s)]


def why_not_run(step: str) -> str:
    """Why ``step`` is not run ("" when it is)."""
    for start, why in NOT_RUN.items():
        if step.startswith(start):
            return why
    argv = shlex.split(step)
    if argv[:1] == ["gasp"] and len(argv) == 2 and argv[1] not in ("engines", "plugins"):
        return "a command named in the text, not a line to run"
    if "my_engine" in argv:
        return "names the reader's own engine (a placeholder)"
    return ""


def readme_lines(text: str | None = None) -> list[Line]:
    """Every command line of the README, in its order: each line of a ``bash`` block, and each inline code span
    of the text that starts with ``gasp `` or ``python ``; ``&&`` chains split into steps."""
    text = README.read_text(encoding="utf-8") if text is None else text
    found = []
    fence = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
    for m in fence.finditer(text):
        if m.group(1) == "bash":
            for ln in m.group(2).splitlines():
                cmd, _, comment = ln.partition(" #")
                if cmd.strip():
                    found.append((m.start(), Line(cmd.strip(), _steps(cmd), comment.strip())))
    outside = fence.sub(lambda m: " " * len(m.group(0)), text)
    for m in re.finditer(r"`((?:gasp|python) [^`\n]+)`", outside):
        found.append((m.start(), Line(m.group(1), _steps(m.group(1)))))
    return [ln for _, ln in sorted(found, key=lambda p: p[0])]


def _steps(cmd: str) -> list[str]:
    return [s.strip() for s in cmd.split("&&") if s.strip()]


def cut_frames(step: str, frames: int | None) -> str:
    """``step`` with ``--frames frames`` (replacing a ``--frames`` it has) when it simulates; as is for None."""
    argv = shlex.split(step)
    if frames is None or argv[:2] not in (["gasp", "simulate"], ["gasp", "compare"]):
        return step
    if "--frames" in argv:
        i = argv.index("--frames")
        argv[i + 1] = str(frames)
    else:
        argv += ["--frames", str(frames)]
    return shlex.join(argv)


def clone(where: Path) -> Path:
    """A copy of the clone at ``where``: every top-level entry of the repository linked, except ``out`` and the
    ones git ignores; the lines' outputs land in it."""
    where.mkdir(parents=True, exist_ok=True)
    for p in ROOT.iterdir():
        if p.name not in ("out", ".git", ".venv", ".pytest_cache") and not p.name.startswith("."):
            (where / p.name).symlink_to(p)
    return where


def env() -> dict:
    """The environment a user has after ``. .venv/bin/activate``: this interpreter's ``bin`` first on PATH."""
    e = dict(os.environ)
    e["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{e.get('PATH', '')}"
    e.pop("GASP_LOAD_PLUGINS", None)
    return e


def run_line(step: str, cwd: Path, timeout: float = 1800) -> subprocess.CompletedProcess:
    """``step`` run by ``bash -c`` in ``cwd``, its output captured."""
    return subprocess.run(["bash", "-c", step], cwd=cwd, env=env(), capture_output=True, text=True, timeout=timeout)


def serve_and_stop(step: str, cwd: Path, probe, wait_s: float = 180) -> tuple[str, str, object]:
    """Start a server line (``gasp view``, ``gasp studio``), wait for the line with its URL, call ``probe(url)``
    while it serves, then stop it as a user does (Ctrl-C). Returns (the URL it printed, everything it printed,
    what ``probe`` returned; None without a URL)."""
    p = subprocess.Popen(shlex.split(step), cwd=cwd, env=env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, start_new_session=True)
    out, url, probed, t0 = [], "", None, time.monotonic()
    try:
        while time.monotonic() - t0 < wait_s and p.poll() is None:
            ln = p.stdout.readline()
            out.append(ln)
            m = re.search(r"http://\S+", ln)
            if m:
                url = m.group(0)
                probed = probe(url)
                break
    finally:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    return url, "".join(out) + (p.stdout.read() or ""), probed


def stray_files(copy: Path) -> list[str]:
    """Entries of the copy's root that a line wrote (anything not a link to the repository, not ``out``)."""
    return sorted(p.name for p in copy.iterdir() if not p.is_symlink() and p.name != "out")
