"""The test tiers of this repository (``docs/reliability.md``, "Tests").

``python -m pytest`` runs the default tier (``pyproject.toml``: ``-m 'not slow'``), meant to stay near 20 minutes
on a 2-core CPU (docs/reliability.md gives the measured times); ``python -m pytest -m slow`` runs the rest. A test
is slow when it carries ``@pytest.mark.slow`` or is listed in ``tests/slow_tier.txt``: one line per test,
``SECONDS NODEID``, where SECONDS is what the test took in a full run on the 2-core machine (its fixtures included)
and NODEID is a pytest node id, or a test function's id without its parameters (all of them), or a file. The list
is kept where the measurement is: each entry's file must exist and define its test function, else the run stops
with the entry's line.
"""
from __future__ import annotations

from pathlib import Path

import pytest

TIER_FILE = Path(__file__).resolve().parent / "tests" / "slow_tier.txt"


def slow_entries(path: Path = TIER_FILE) -> dict[str, int]:
    """``{node id or prefix: line number}`` from the tier file (blank lines and ``#`` comments skipped)."""
    entries = {}
    if path.exists():
        for i, line in enumerate(path.read_text().splitlines(), 1):
            line = line.split("#", 1)[0].strip()
            if line:
                parts = line.split(None, 1)
                if len(parts) != 2:
                    raise pytest.UsageError(f"{path}:{i}: expected 'SECONDS NODEID', got {line!r}")
                entries[parts[1]] = i
    return entries


def _matches(nodeid: str, entry: str) -> bool:
    return nodeid == entry or nodeid.split("[", 1)[0] == entry or nodeid.split("::", 1)[0] == entry


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session, config, items):
    """Mark the listed tests ``slow`` before ``-m`` selects (``tryfirst``)."""
    entries = slow_entries()
    for item in items:
        if any(_matches(item.nodeid, e) for e in entries):
            item.add_marker(pytest.mark.slow)
    stale = [e for e in entries if not _names_a_test(e)]
    if stale:
        raise pytest.UsageError(f"{TIER_FILE}:{entries[stale[0]]}: '{stale[0]}' names no test of this repository "
                                f"({len(stale)} such entries); remove or correct it")


def _names_a_test(entry: str) -> bool:
    """The entry's file exists and defines its test function (checked in the source, so that a module skipped for
    a missing optional package does not make its entries look stale)."""
    path, _, rest = entry.partition("::")
    file = TIER_FILE.parent.parent / path
    if not file.is_file():
        return False
    name = rest.split("[", 1)[0].split("::")[-1]
    return not name or f"def {name}(" in file.read_text()
