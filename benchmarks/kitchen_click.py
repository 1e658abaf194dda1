"""Issue 54's studio must-show: does a click on the spinach of ``examples/kitchen_spinach.toml`` select the spinach?

The known answer is the example's own selection: the 351 Gaussians whose centres (file frame, model time 0.5) lie in
its ``select = { box = ... }`` (:func:`pile_rows`). A click is simulated as the studio gets it (no browser): a ray
from a camera 0.6 m above a spinach Gaussian straight down onto it, or from 0.5 m above and 0.5 m in front
(world -y) onto it (:func:`spinach_rays`, 8 of each, the Gaussians drawn with a fixed seed), handed to
:meth:`gasp_core.studio.app.Studio.click`, which casts it (``ray_pick``) and selects by its rule. Each click's
selection is scored against the box: **recall** (the share of the 351 box rows selected), **precision** (the share
of the selection in the box) and **outside**: selected Gaussians whose centre lies more than :data:`OUTSIDE` metres
outside the box (world frame; the pan's bottom is 2.7 cm below the box, the counter further, the pan's dark wall
from about 12 to 16 cm from the pile's centre against the box's 13.7 cm). The aim (issue 54): recall >= 0.9 and
at most :data:`MAX_OUTSIDE` of the box's count outside.

Run: ``python benchmarks/kitchen_click.py``: prints one line per click (about 10 s) and writes them to
``benchmarks/results/kitchen_click.md``.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
#: A selected centre this far outside the box (metres, world) is not spinach: the pan's bottom, wall or counter.
OUTSIDE = 0.02
#: The aim: recall and precision at least these, and at most this share of the box's count outside.
MIN_RECALL, MIN_PRECISION, MAX_OUTSIDE = 0.8, 0.8, 0.05
#: Camera offsets from the clicked Gaussian, world metres (z up): straight above, and above and in front.
VIEWS = {"above": (0.0, 0.0, 0.6), "front": (0.0, -0.5, 0.5)}


def pile_rows(piece) -> np.ndarray:
    """Rows of the example's ``select`` box (file frame), sorted: the known answer (351 rows)."""
    import tomllib
    box = tomllib.loads(KITCHEN.read_text())["object"][0]["select"]["box"]
    x = piece.gaussians.means
    return np.flatnonzero(np.all((x >= box["lo"]) & (x <= box["hi"]), axis=1))


def spinach_rays(piece, rows: np.ndarray, n: int = 8, seed: int = 1):
    """``(view, row, origin, direction)`` for ``n`` box rows per view of :data:`VIEWS` (world metres)."""
    rng = np.random.default_rng(seed)
    out = []
    for view, off in VIEWS.items():
        for r in rng.choice(rows, n, replace=False):
            origin = piece.means[r] + np.asarray(off)
            out.append((view, int(r), origin, piece.means[r] - origin))
    return out


def score(selected: np.ndarray, rows: np.ndarray, means: np.ndarray) -> dict:
    """``n``, ``recall``, ``precision`` and ``outside`` (count) of a boolean selection against the box ``rows``."""
    inside = np.zeros(len(selected), bool)
    inside[rows] = True
    lo, hi = means[rows].min(axis=0), means[rows].max(axis=0)
    gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - means, means - hi)), axis=1)
    n = int(selected.sum())
    return {"n": n, "recall": float(selected[rows].mean()), "precision": float(inside[selected].mean()) if n else 0.0,
            "outside": int((selected & (gap > OUTSIDE)).sum())}


def measure(studio, n: int = 8) -> list[dict]:
    """Each simulated click's :func:`score` (plus ``view`` and ``row``; ``n`` clicks per view), the studio's rule as
    it stands."""
    p = studio.scene.pieces[0]
    rows = pile_rows(p)
    out = []
    for view, row, origin, direction in spinach_rays(p, rows, n):
        p.selected[:] = False                  # each click on its own (a click on a selected piece removes it)
        studio.click(origin, direction)
        out.append({"view": view, "row": row, **score(p.selected.copy(), rows, p.means)})
    return out


def open_studio(workdir):
    """A :class:`gasp_core.studio.app.Studio` on the kitchen example (no warm-up), its pieces found."""
    from gasp_core.studio.app import Studio
    st = Studio(KITCHEN, Path(workdir), port=0, warm=False)
    t0 = time.time()
    while st.labels[0] is None and time.time() - t0 < 120:
        time.sleep(0.05)
    return st


def main() -> None:
    st = open_studio(tempfile.mkdtemp(prefix="kitchen_click_"))
    lines = []
    try:
        for r in measure(st):
            lines.append(f"{r['view']:5s} row {r['row']:6d}: {r['n']:6d} selected, recall {r['recall']:.3f}, "
                         f"precision {r['precision']:.4f}, outside {r['outside']}")
            print(lines[-1], flush=True)
    finally:
        st.stop()
    out = Path(__file__).resolve().parent / "results" / "kitchen_click.md"
    out.write_text("# A click on the kitchen's spinach against the example's box (`python benchmarks/kitchen_click.py`)"
                   "\n\n```\n" + "\n".join(lines) + "\n```\n")


if __name__ == "__main__":
    sys.exit(main())
