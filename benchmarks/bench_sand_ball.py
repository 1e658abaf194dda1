"""Issue 53 item 3: a sand column collapsing against a jelly ball, with and without the two-field contact.

The scene and the figures are ``gasp_core.testing.sand_ball``'s (a 6 x 6 x 15 cm sand column, friction angle 30,
against a 5 cm jelly ball 5 mm from its face; n_grid 32 on 0.48 m, dx 15 mm): the share of the sand held on the
ball's side steeper than 50 degrees, the sand's height against the ball over the free pile's, the deepest sand point
inside the ball (dx), the ball's turn (degrees). Per engine, with the column's fill alone and with points 5 mm apart
on its faces (``surface``), the two-field contact on (the default) and off (``contact_fields = false``: one field,
as before issue 53), and the free pile (no ball).

    python benchmarks/bench_sand_ball.py --engines warp_mpm,taichi_mpm --frames 60

Writes ``benchmarks/results/sand_ball.json`` (or ``--out``), a JSON line per run, as each run ends; a run that
diverges records its frame and message.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def run(engine: str, frames: int, ball: bool, surface: bool, fields: bool):
    """(positions per frame, setup, wall seconds, divergence message or None)."""
    from gasp_core.seam import EngineDivergence
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    setup = S.pair_setup(ball=ball, surface=surface, options={"threads": 1, "contact_fields": fields})
    t = time.perf_counter()
    try:
        tr = run_trace(get_engine(engine), setup, frames)
    except EngineDivergence as e:
        return None, setup, time.perf_counter() - t, f"frame {e.frame}: {e}"
    return tr.x, setup, time.perf_counter() - t, None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--surfaces", default="0,1", help="0: the fill alone, 1: with points 5 mm apart on the faces")
    ap.add_argument("--out", default=str(HERE / "results" / "sand_ball.json"))
    a = ap.parse_args()
    from gasp_core.testing import sand_ball as S
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".part")
    lines = []
    for engine in a.engines.split(","):
        for surface in (s == "1" for s in a.surfaces.split(",")):
            free, _s, sec_free, err_free = run(engine, a.frames, False, surface, True)
            for fields in (True, False):
                x, setup, sec, err = run(engine, a.frames, True, surface, fields)
                row = {"engine": engine, "surface": surface, "contact_fields": fields, "frames": a.frames,
                       "points": len(setup.x), "seconds": round(sec, 1), "diverged": err}
                if x is not None and free is not None:
                    row.update({k: round(v, 4) for k, v in
                                S.pair_figures(x[0], x[-1], np.asarray(setup.body_id), free[-1]).items()})
                lines.append(json.dumps(row))
                print(lines[-1], flush=True)
                tmp.write_text("\n".join(lines) + "\n")
            if err_free:
                print(json.dumps({"engine": engine, "surface": surface, "free_pile_diverged": err_free}))
    os.replace(tmp, out)


if __name__ == "__main__":
    main()
