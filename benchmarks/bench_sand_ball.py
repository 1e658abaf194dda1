"""Issue 53 item 3: a sand column collapsing against a jelly ball, with and without the two-field contact.

The scene and the figures are ``gasp_core.testing.sand_ball``'s (a 6 x 6 x 15 cm sand column, friction angle 30,
against a 5 cm jelly ball 5 mm from its face; n_grid 32 on 0.48 m, dx 15 mm): the share of the sand held on the
ball's side steeper than 50 degrees, the sand's height against the ball over the free pile's, the deepest sand point
inside the ball (dx), the ball's turn (degrees). Per engine, with the column's fill alone and with points 5 mm apart
on its faces (``surface``), the two-field contact on (the default) and off (``contact_fields = false``: one field,
as before issue 53), and the free pile (no ball).

    python benchmarks/bench_sand_ball.py --engines warp_mpm,taichi_mpm --frames 60
    python benchmarks/bench_sand_ball.py --light --out benchmarks/results/sand_ball_light.json
    python benchmarks/bench_sand_ball.py --rigid --out benchmarks/results/sand_ball_rigid.json

Writes ``benchmarks/results/sand_ball.json`` (or ``--out``), a JSON line per run, as each run ends; a run that
diverges records its frame and message.

``--sha FRAMES`` instead prints the sha1 of the positions after FRAMES frames of the scenes the contact must leave
bit for bit (the column alone; the pair with ``contact = "grid"``; the pair with one field), per engine: run it on
two checkouts and compare (on a checkout before issue 53, ``--sha-base`` leaves out the option it lacks), e.g.
``PYTHONPATH=BASE:BASE/plugins/taichi_mpm:BASE/plugins/warp_mpm python benchmarks/bench_sand_ball.py --sha 10
--sha-base`` against the same line with this checkout's paths and without ``--sha-base``.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def run(engine: str, frames: int, ball: bool, surface: bool, fields: bool, light: bool = False, rigid: bool = False):
    """(positions per frame, setup, wall seconds, divergence message or None)."""
    from gasp_core.seam import EngineDivergence
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    setup = S.pair_setup(ball=ball, surface=surface, options={"threads": 1, "contact_fields": fields}, light=light,
                         rigid=rigid)
    t = time.perf_counter()
    try:
        tr = run_trace(get_engine(engine), setup, frames)
    except EngineDivergence as e:
        return None, setup, time.perf_counter() - t, f"frame {e.frame}: {e}"
    return tr.x, setup, time.perf_counter() - t, None


def sha(engines: list[str], frames: int, base: bool) -> None:
    """Print ``engine scene sha1`` for the scenes of ``--sha``."""
    import hashlib
    import importlib.util
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    # this checkout's scene, also when PYTHONPATH points at another checkout (which may not have it)
    spec = importlib.util.spec_from_file_location("sand_ball", HERE.parent / "gasp_core" / "testing" / "sand_ball.py")
    S = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(S)
    one = {} if base else {"contact_fields": False}
    scenes = {"sand_alone": (False, {}), "pair_grid": (True, {"contact": "grid"}), "pair_one_field": (True, one)}
    for engine in engines:
        for name, (ball, opts) in scenes.items():
            tr = run_trace(get_engine(engine), S.pair_setup(ball=ball, options={"threads": 1, **opts}), frames)
            print(engine, name, hashlib.sha1(np.ascontiguousarray(tr.x[-1]).tobytes()).hexdigest(), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--surfaces", default="0,1", help="0: the fill alone, 1: with points 5 mm apart on the faces")
    ap.add_argument("--out", default=str(HERE / "results" / "sand_ball.json"))
    ap.add_argument("--light", action="store_true", help="the light ball (E 2e4, rho 300) touching the column")
    ap.add_argument("--rigid", action="store_true", help="the ball on the rigid route (model = 'rigid')")
    ap.add_argument("--sha", type=int, default=0, metavar="FRAMES")
    ap.add_argument("--sha-base", action="store_true")
    a = ap.parse_args()
    if a.sha:
        return sha(a.engines.split(","), a.sha, a.sha_base)
    from gasp_core.testing import sand_ball as S
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".part")
    lines = []
    for engine in a.engines.split(","):
        for surface in (s == "1" for s in a.surfaces.split(",")):
            free, _s, sec_free, err_free = run(engine, a.frames, False, surface, True)
            for fields in (True, False):
                x, setup, sec, err = run(engine, a.frames, True, surface, fields, a.light, a.rigid)
                row = {"engine": engine, "ball": ("light" if a.light else "default") + (", rigid" if a.rigid else ""),
                       "surface": surface,
                       "contact_fields": fields, "frames": a.frames,
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
