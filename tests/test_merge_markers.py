"""No tracked text file keeps a merge's conflict markers (round 43 committed three into ``docs/contact.md``).

A marker is a line that is exactly ``=======`` or starts with ``<<<<<<< `` or ``>>>>>>> `` (git's own, ``git
merge-file``); reStructuredText table rules (``====  ====``) and Markdown underlines of other lengths are not.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MARKER = re.compile(r"^(<{7} |>{7} |={7}$)", re.M)
TEXT = (".py", ".md", ".toml", ".txt", ".cfg", ".yml", ".yaml", ".json", ".html", ".js", ".css", ".sh")


def markers(paths: list[Path]) -> list[str]:
    """``file:line`` of every conflict marker in ``paths`` (text files, read as UTF-8, undecodable bytes replaced)."""
    hits = []
    for p in paths:
        text = p.read_text(encoding="utf-8", errors="replace")
        hits += [f"{p}:{text.count(chr(10), 0, m.start()) + 1}" for m in MARKER.finditer(text)]
    return hits


def _tracked() -> list[Path]:
    out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    names = [n for n in out.decode().split("\0") if n.endswith(TEXT) or Path(n).name == ".ci"]
    return [ROOT / n for n in names if (ROOT / n).is_file()]


def test_no_tracked_text_file_has_conflict_markers():
    assert not markers(_tracked())


def test_catch_a_file_with_a_conflict_is_named(tmp_path):
    bad = tmp_path / "doc.md"
    bad.write_text("# t\n\n<<<<<<< HEAD\nours\n=======\ntheirs\n>>>>>>> branch\n")
    good = tmp_path / "table.py"
    good.write_text('"""\n=======  ====\nname     x\n=======  ====\n"""\n# ======= not at the start\n')
    assert markers([bad, good]) == [f"{bad}:3", f"{bad}:5", f"{bad}:7"]
