"""Issue 54's studio must-show on the real kitchen capture: a click on the spinach selects the spinach
(``benchmarks/kitchen_click.py``), and the spinach so selected lands in the pan with no Gaussian beyond its wall
(``benchmarks/kitchen_wall.py``).

The kitchen is a dynamic model, so the studio's click selects the moving piece the clicked splat belongs to
(:mod:`gasp_core.studio.pieces`). The known answer is the example's hand-measured select box (351 rows). 57 of them
(16 %) are a still, brown end of the box (median motion 0.6 cm against 3.1 cm for the leaves selected; mean colour
(0.35, 0.30, 0.21) against (0.55, 0.57, 0.29)): the pan caught by the box (docs/colliders.md). So the aim per click
is recall >= 0.8 (not 0.9) with precision >= 0.8 and at most 5 % of the box's count more than 2 cm outside it
(``kitchen_click.MIN_RECALL``, ``MIN_PRECISION``, ``MAX_OUTSIDE``).
"""
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


def meets(r: dict) -> bool:
    """The aim per click (module notes)."""
    return r["recall"] >= kc.MIN_RECALL and r["precision"] >= kc.MIN_PRECISION and r["outside"] <= kc.MAX_OUTSIDE * 351


def test_the_score_counts_what_lies_outside_the_box():
    """Known answer: a 2 x 2 x 2 cm box of 8 rows; a selection of 6 of them, one row 1 cm outside a face and one
    3 cm outside: recall 6/8, precision 6/8, one outside by more than 2 cm."""
    box = np.array([[x, y, z] for x in (0, 0.02) for y in (0, 0.02) for z in (0, 0.02)], float)
    means = np.vstack([box, [[0.03, 0.01, 0.01], [0.05, 0.01, 0.01]]])
    sel = np.zeros(10, bool)
    sel[[0, 1, 2, 3, 4, 5, 8, 9]] = True
    s = kc.score(sel, np.arange(8), means)
    assert s == {"n": 8, "recall": 0.75, "precision": 0.75, "outside": 1}


@pytest.fixture(scope="module")
def kitchen_studio(tmp_path_factory):
    st = kc.open_studio(tmp_path_factory.mktemp("studio"))
    yield st
    st.stop()


def test_a_click_on_the_spinach_selects_the_spinach(kitchen_studio):
    """The benchmark's 16 clicks (8 from above, 8 from above and in front, aimed at box rows): at least 12 meet the
    aim, all with the same selection (measured: 12, 342 Gaussians, recall 0.838, precision 0.86, 15 outside). The
    other 4 meet the pan, the cook's hand or dark Gaussians 5-7 cm from the moving leaves (docs/colliders.md)."""
    got = kc.measure(kitchen_studio, n=8)
    good = [r for r in got if meets(r)]
    assert len(good) >= 12, got
    assert len({r["n"] for r in good}) == 1, good
    assert 0.8 <= good[0]["recall"] <= 0.9 and good[0]["precision"] <= 0.95, good[0]


def test_the_still_captures_rule_fails_the_same_aim(kitchen_studio):
    """The check catches a rule that ignores the motion: with the dynamic model's moving pieces dropped, the click
    takes its connected piece (61,026 Gaussians, most of the kitchen) and no click meets the aim."""
    saved = kitchen_studio.moving[0]
    kitchen_studio.moving[0] = None
    try:
        got = kc.measure(kitchen_studio, n=2)
    finally:
        kitchen_studio.moving[0] = saved
    assert not any(meets(r) for r in got), got
    assert min(r["n"] for r in got) > 10_000, got


@pytest.mark.slow
def test_the_clicked_spinach_lands_in_the_pan(kitchen_studio, tmp_path):
    """End to end, the must-show's words: one click on the spinach, the scene saved as the studio saves it
    (``select = { mask }``), 30 frames of ``gasp simulate``: no spinach Gaussian beyond the pan's wall at the last
    frame (:func:`kitchen_wall.measure`; measured 0 of 342, the farthest 0.17 dx inside the wall), and the default
    camera of ``gasp render`` frames it: over the 31 frames the moving rows' projected box covers at least a quarter
    of the picture (measured 0.296-0.304; the example's box selection 0.395-0.424, and 0.001 framing the whole
    scene, ``tests/test_render_framing.py``; the share depends on the part's shape, the camera fits its 3D box)."""
    import subprocess
    import kitchen_wall as kw
    from gasp_core.render.run import load_run, moving_mask, run_view
    from test_render_framing import box_share
    p = kitchen_studio.scene.pieces[0]
    _, row, origin, direction = kc.spinach_rays(p, kc.pile_rows(p), 8)[1]
    p.selected[:] = False
    kitchen_studio.click(origin, direction)
    assert meets(kc.score(p.selected.copy(), kc.pile_rows(p), p.means))
    scene = kitchen_studio.scene.write(tmp_path / "clicked.toml")
    out = tmp_path / "run"
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q"],
                   check=True, cwd=ROOT)
    m = kw.measure(out)
    assert m["n"] == int(p.selected.sum()) and m["beyond"][0.0] == 0, m
    run = load_run(out)
    frames = [run.splats(f) for f in range(run.n_frames)]
    mask = moving_mask(run)
    cam = run_view([run], frames)[0].camera
    assert min(box_share(cam, s.means[mask]) for s in frames) >= 0.25
    assert box_share(run_view([run], frames, "scene")[0].camera, frames[-1].means[mask]) < 0.01
