"""Issue 54's studio must-show, with a known answer on the real kitchen capture: a click on the spinach selects the
spinach (the example's box rows, ``benchmarks/kitchen_click.py``). Not met yet (docs/colliders.md, "Not done: the
studio's click"): the click selects its connected piece, 61,026 of the 62,442 Gaussians, so the test is an
expected failure until a rule meets it (strict: a rule that meets it turns it into a failure, to drop the mark)."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from gasp_testing import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import kitchen_click as kc  # noqa: E402

pytest.importorskip("viser", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytest.importorskip("tomli_w", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytestmark = pytest.mark.skipif(not (kc.KITCHEN.parent / "data" / "spinach_4.splatv").is_file(),
                                reason="examples/data/spinach_4.splatv missing")


def test_the_score_counts_what_lies_outside_the_box():
    """Known answer: a 2 x 2 x 2 cm box of 8 rows; a selection of 6 of them, one row 1 cm outside a face and one
    3 cm outside: recall 6/8, precision 6/8, one outside by more than 2 cm."""
    box = np.array([[x, y, z] for x in (0, 0.02) for y in (0, 0.02) for z in (0, 0.02)], float)
    means = np.vstack([box, [[0.03, 0.01, 0.01], [0.05, 0.01, 0.01]]])
    sel = np.zeros(10, bool)
    sel[[0, 1, 2, 3, 4, 5, 8, 9]] = True
    s = kc.score(sel, np.arange(8), means)
    assert s == {"n": 8, "recall": 0.75, "precision": 0.75, "outside": 1}


@pytest.mark.xfail(strict=True, reason="issue 54: the click selects the connected piece, 61,026 of 62,442 "
                                       "Gaussians (docs/colliders.md 'Not done: the studio's click')")
def test_a_click_on_the_spinach_selects_the_spinach(tmp_path):
    """8 clicks (4 from above, 4 from above and in front) on spinach Gaussians: each selects at least 90 % of the
    351 box rows and at most 5 % of that count more than 2 cm outside the box (pan bottom, wall, counter)."""
    st = kc.open_studio(tmp_path / "studio")
    try:
        got = kc.measure(st, n=4)
    finally:
        st.stop()
    assert len(got) == 8
    for r in got:
        assert r["recall"] >= kc.MIN_RECALL and r["outside"] <= kc.MAX_OUTSIDE * 351, r
