"""benchmarks/ holds what a maintainer re-runs (issue 39, item 6): every script there is in the index of
``docs/performance.md`` ("The benchmarks") with the results it writes, and every one-off study in
``benchmarks/studies/`` is in that folder's README."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"


def table_rows(text: str) -> dict[str, list[str]]:
    """``{script: [cells after the first]}`` of the markdown table rows whose first cell is a backquoted file."""
    rows = {}
    for line in text.splitlines():
        m = re.match(r"\|\s*`([\w.]+)`\s*\|(.*)\|\s*$", line)
        if m:
            rows[m.group(1)] = [c.strip() for c in m.group(2).split("|")]
    return rows


def test_every_benchmark_is_indexed_with_its_results():
    text = (ROOT / "docs" / "performance.md").read_text()
    section = text[text.index("## The benchmarks"):]
    section = section[:section.index("\n## ", 1)]
    rows = table_rows(section)
    scripts = {p.name for p in BENCH.iterdir() if p.suffix in (".py", ".sh")}
    assert set(rows) == scripts, (sorted(scripts - set(rows)), sorted(set(rows) - scripts))
    results = [p.name for p in (BENCH / "results").iterdir()]
    for script, cells in rows.items():
        prefix = cells[-1].strip("`")
        assert prefix and any(r.startswith(prefix) for r in results), f"{script}: no results/{prefix}*"


def test_every_study_is_in_the_studies_readme():
    rows = table_rows((BENCH / "studies" / "README.md").read_text())
    assert set(rows) == {p.name for p in (BENCH / "studies").glob("*.py")}
