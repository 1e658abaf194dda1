"""``docs/must_shows.md`` claims no more than the suite holds: every test it names exists, a "not met" row names a
strict xfail (or no test at all), and a "met" row names no test that is a strict xfail as a whole."""
from __future__ import annotations

import re

from gasp_testing import ROOT

LEDGER = ROOT / "docs" / "must_shows.md"
NODE = re.compile(r"`((?:tests|conformance_tests)/[\w/]+\.py)::(\w+)`")
BARE = re.compile(r"`(test_\w+)`")
FILE = re.compile(r"`((?:tests|conformance_tests)/[\w/]+\.py)")


def rows() -> list[tuple[str, str, list[tuple[str, str]]]]:
    """``(must-show, state, [(file, test), ...])`` for each table row; a bare test name belongs to the file named
    last before it in the row."""
    out = []
    for line in LEDGER.read_text().splitlines():
        if not line.startswith("| ") or line.startswith("| must-show") or line.startswith("|---"):
            continue
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        assert len(cells) == 3, f"docs/must_shows.md: a row of {len(cells)} cells, expected 3: {line[:80]}"
        named, last = [], None
        for m in re.finditer(r"`[^`]+`", cells[1]):
            token = m.group(0)
            if (n := NODE.fullmatch(token)) is not None:
                last = n.group(1)
                named.append((n.group(1), n.group(2)))
            elif (b := BARE.fullmatch(token)) is not None:
                assert last is not None, f"docs/must_shows.md: {token} names no file before it: {line[:80]}"
                named.append((last, b.group(1)))
            elif (f := FILE.match(token)) is not None:
                last = f.group(1)
        out.append((cells[0], cells[2], named))
    return out


def strict_xfail(path: str, name: str) -> bool:
    """Whether ``def name`` in ``path`` carries ``@pytest.mark.xfail(strict=True ...)`` among its decorators (a
    whole-test mark; a strict xfail on some of its parameters is not one)."""
    lines = (ROOT / path).read_text().splitlines()
    i = next((k for k, s in enumerate(lines) if re.match(rf"def {name}\(", s)), None)
    if i is None:
        return False   # test_every_named_test_exists names it
    k = i - 1
    while k >= 0 and (lines[k].startswith("@") or lines[k].startswith((" ", ")"))) and lines[k].strip():
        if lines[k].startswith("@pytest.mark.xfail(strict=True"):
            return True
        k -= 1
    return False


def test_every_named_test_exists():
    missing = [f"{p}::{n}" for _, _, named in rows() for p, n in named
               if not (ROOT / p).is_file() or not re.search(rf"^def {n}\(", (ROOT / p).read_text(), re.M)]
    assert rows() and not missing, missing


def test_not_met_rows_are_strict_xfails_and_met_rows_are_not():
    bad = []
    for claim, state, named in rows():
        xfails = [strict_xfail(p, n) for p, n in named]
        if state.startswith("**not met"):
            if named and not any(xfails):
                bad.append(f"'{claim[:50]}' is not met but names no strict xfail")
        elif any(xfails):
            bad.append(f"'{claim[:50]}' is called {state[:20]!r} but names a strict xfail")
    assert not bad, bad


def test_the_check_reads_a_strict_xfail():
    """Known answers from the suite: a strict xfail, and a plain test beside it."""
    assert strict_xfail("tests/test_brittle_readme_donut.py", "test_the_donut_placed_1_m_up_in_the_default_domain_ends_in_pieces")
    assert not strict_xfail("tests/test_brittle_readme_donut.py", "test_the_brittle_readme_donut_from_1_m_is_not_dust")
