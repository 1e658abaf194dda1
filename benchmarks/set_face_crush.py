"""The material by a set box's face (issue 66, round 40, docs/fracture.md "Round 40"): a specimen of the tension family
built through the scene (``benchmarks/user_oblique.py``: turned about z by ``angle`` deg, held by a ``fixed_region``,
pulled by one ramped ``[[impulse]] mode = "set"`` box), run for ``--frames`` frames; every frame, over the material
points within :data:`BAND` cells of the set box's face (either side), the smallest and largest singular value of
``F`` and the largest speed relative to the box (in pulls, ``|v - v_set| / PULL``), with the set box's image gradient
by mass (``grid_tables.IMAGE_BY_MASS``, the rule since round 40: ``new``) or every image node at full weight
(``old``, the rule before).

Round 39 traced the oblique 1.5:1 at 45 deg, n_grid 48: material points by the pulled face crushed to 0.34 of their
length from frame 502 and springing off at 2-3.9 m/s at frames 518-524 (the shed crumbs that carry vertices away).
Round 40 traced it to a set box's point 0.29 cells inside the face whose ``F`` the image gradient crushed (singular
value 0.007 at frame 480) from a node of tiny mass at its image's stencil; this measures that crush on a family.

``--face clamp`` reads the same band by the ``fixed_region``'s face (held at rest), ``--image`` then naming its ghost
rule: ``new`` its image nodes by mass (``grid_tables.FIXED_BY_MASS``, round 40's clamp fix), ``old`` at full weight.

Run: ``python benchmarks/set_face_crush.py --engine warp_mpm`` (and ``taichi_mpm``; ``--cases``
``dogbone_1.5to1:45:48,...`` as specimen:angle:n_grid, ``--image new,old``, ``--frames``); rows are added to
``benchmarks/results/set_face_crush.json`` and ``set_face_crush.md`` is written from it. One engine per process.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
OUT = RESULTS / "set_face_crush.json"
BAND = 2.0   # cells either side of the set box's face
CASES = "dogbone_1.5to1:45:48,dogbone_2to1:45:48,dogbone_1.5to1:0:48,dogbone_1.5to1:45:32,bar_L0.9_a0.15:45:32"


def fixed(engine: str, which: str):
    """A ``fixed_region``'s ghost rule: ``new``, its image nodes by mass (``grid_tables.FIXED_BY_MASS``, round 40);
    ``old``, any image node with mass at full weight (the rule before). Raises ``ValueError`` on another name."""
    import passive_specks as ps
    return ps.rule_switch(engine, "FIXED_BY_MASS", which, "--image at the clamp", [("held", "build_mirror")])


def face_run(engine: str, specimen: str, angle: str, n_grid: int, n_frames: int, which: str = "new",
             every: int = 1, at: str = "set") -> dict:
    """Run ``specimen`` at ``angle`` deg on ``n_grid`` for ``n_frames`` frames with the image rule ``which``
    (``passive_specks.image``). Returns per frame read (every ``every``-th, and the last) ``sv_min``, ``sv_max``
    (the smallest and largest singular value of ``F`` over the material points within :data:`BAND` cells of the
    face ``at``: ``"set"`` the set box's, ``"clamp"`` the ``fixed_region``'s; ``sv_min_in``, ``sv_min_out`` the
    smallest inside the box and outside it) and ``rel`` (their largest ``|v - v_held|``, in pulls; ``v_held`` the
    box's velocity, 0 at the clamp); with ``dx`` (m) and ``face`` (m). At the clamp ``which`` is the clamp's ghost
    rule (:func:`fixed`), the set box's image rule its default."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import passive_specks as ps
    import tension_family as tf
    import user_oblique as uo
    from gasp_core.testing import specks
    setup = uo.prepare(uo.SPECIMENS[specimen], n_grid, engine, angle)[0].setup
    imp = setup.impulses[0]
    face, dx, dv = float(imp.lo[0]), float(setup.dx), np.asarray(imp.velocity_change, float)
    ramp = float(getattr(imp, "ramp", 0.0) or 0.0)
    if at == "clamp":   # the fixed_region's face (x <= face), held at rest
        face = float(next(b for b in setup.boundaries if b.kind == "fixed_region").hi[0])
        dv = np.zeros(3)
    out = {"sv_min": [], "sv_min_in": [], "sv_min_out": [], "sv_max": [], "rel": [], "dx": dx, "face": face}
    with (fixed(engine, which) if at == "clamp" else ps.image(engine, which)):
        e = specks.build_engine(specks.engines()[engine], setup)
        inner = getattr(e, "inner", e)
        try:
            for f in range(1, n_frames + 1):
                e.step_frame()
                if f % every and f != n_frames:
                    continue
                s = inner.get_state()
                x, v = np.asarray(s["x"], float), np.asarray(s["v"], float)
                near = np.abs(x[:, 0] - face) < BAND * dx
                sv = np.linalg.svd(np.asarray(s["F"], float).reshape(-1, 3, 3)[near], compute_uv=False)
                vs = dv * min(1.0, f * setup.frame_dt / ramp) if ramp > 0 else dv
                held = (x[near, 0] <= face) if at == "clamp" else (x[near, 0] >= face)   # inside the box
                out["sv_min"].append(float(sv.min()))
                out["sv_min_in"].append(float(sv[held].min(initial=np.inf)))
                out["sv_min_out"].append(float(sv[~held].min(initial=np.inf)))
                out["sv_max"].append(float(sv.max()))
                out["rel"].append(float(np.linalg.norm(v[near] - vs, axis=1).max() / tf.PULL))
        finally:
            e.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", required=True)
    ap.add_argument("--cases", default=CASES, help="specimen:angle:n_grid, comma separated")
    ap.add_argument("--image", default="new,old")
    ap.add_argument("--frames", type=int, default=530)
    ap.add_argument("--face", default="set", choices=("set", "clamp"), help="the set box's face or the clamp's")
    a = ap.parse_args()
    rows = json.loads(OUT.read_text()) if OUT.exists() else []
    for case in a.cases.split(","):
        specimen, angle, n_grid = case.split(":")
        for which in a.image.split(","):
            t0 = time.perf_counter()
            r = face_run(a.engine, specimen, angle, int(n_grid), a.frames, which, at=a.face)
            below = [i + 1 for i, s in enumerate(r["sv_min"]) if s < 0.9]
            row = {"case": case, "engine": a.engine, "image": which, "frames": a.frames, "face": a.face,
                   "sv_min": round(min(r["sv_min"]), 4), "sv_max": round(max(r["sv_max"]), 4),
                   "sv_min_in": round(min(r["sv_min_in"]), 4), "sv_min_out": round(min(r["sv_min_out"]), 4),
                   "first_below_0.9": below[0] if below else None, "rel_max": round(max(r["rel"]), 2),
                   "sv_min_every_50": [round(min(r["sv_min"][i:i + 50]), 4) for i in range(0, a.frames, 50)],
                   "wall_s": round(time.perf_counter() - t0, 1)}
            print(json.dumps(row), flush=True)
            rows = [x for x in rows if (x["case"], x["engine"], x["image"], x["frames"], x.get("face", "set")) !=
                    (case, a.engine, which, a.frames, a.face)]
            rows.append(row)
            OUT.write_text(json.dumps(rows, separators=(",", ":")))
    write_md(rows)


def write_md(rows: list[dict]) -> None:
    """``set_face_crush.md`` from the rows (a row without ``face`` is the set box's)."""
    lines = ["# The material by a held box's face (issue 66, round 40)", "",
             "`python benchmarks/set_face_crush.py` (docstring). Case: specimen:angle (deg):n_grid, built through the "
             "scene (`user_oblique.prepare`, ramped set box). Face: `set`, the set box's; `clamp`, the "
             "`fixed_region`'s (`--face clamp`). Over the material points within 2 cells of that face, every frame: "
             "the smallest and largest singular value of `F` over the run (the smallest also inside the box and "
             "outside it), the first frame any is under 0.9, the largest speed relative to the box (in pulls, 0.02 "
             "m/s; 0 at the clamp), and the smallest singular value in each 50 frames. Rule at the set box's face: "
             "`new`, a set box's point's image gradient gathers each image node by its mass over its mirror node's "
             "(`grid_tables.IMAGE_BY_MASS`); `old`, every image node with mass at full weight. Rule at the clamp's "
             "face: `new`, the fixed region's ghost nodes take their image nodes by mass (`grid_tables.FIXED_BY_MASS`"
             "); `old`, at full weight (the rule before round 40's clamp fix).", "",
             "| case | face | engine | rule | frames | sv min | in / out | sv max | first under 0.9 | "
             "fastest (pulls) | sv min each 50 frames | s |", "|" + "---|" * 12]
    key = lambda r: (r["case"], r.get("face", "set"), r["engine"], r["image"], r["frames"])   # noqa: E731
    for r in sorted(rows, key=key):
        io = f"{r['sv_min_in']} / {r['sv_min_out']}" if "sv_min_in" in r else "-"
        lines.append(f"| {r['case']} | {r.get('face', 'set')} | {r['engine']} | {r['image']} | {r['frames']} | "
                     f"{r['sv_min']} | {io} | {r['sv_max']} | {r['first_below_0.9'] or '-'} | {r['rel_max']} | "
                     f"{' / '.join(str(s) for s in r['sv_min_every_50'])} | {r['wall_s']} |")
    (RESULTS / "set_face_crush.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
