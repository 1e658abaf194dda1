"""Round 51 (issue 67; docs/contact.md "Round 51: slides over a family of shapes"): the slides and sticks of
``gasp_core.testing.slide_shapes`` over its family (a slab, a cube, a bar along and one across the slope, a disc, a
hexagonal prism, at sizes 1 and 1.5; the bundled donut lying flat at 0.7 and 1), rigid and jelly, ``contact =
"particle"`` and ``"grid"``, n_grid 24 and 32, both MPM engines: per case the figure (a slide's acceleration against
Coulomb's, a stick's travel in 1 s after the settle) and the two-sided check (``--tol``: 2.5 %, the slope tests'). One
case a line on stdout, appended to ``--log`` (JSON lines;
cases already there are not run again), then ``benchmarks/results/slide_shapes.{md,json}`` from the log.

    python benchmarks/slide_shapes.py --engines warp_mpm taichi_mpm --log /tmp/slideshapes/family.jsonl

``--sink``: instead, the rigid body on the grid contact on a flat ground (docs/contact.md "Round 51", found 1): 12 x 12
cm slabs of one, two and four point layers and the 7.5 cm cube, rigid and jelly, n_grid 24, over 1.1 s: the
centroid's drop and the lowest point's height over the plane (mm), one line each
(``benchmarks/results/slide_shapes_sink.txt``).
"""
import argparse
import json
import math
import time
from pathlib import Path

from gasp_core.testing import slide_shapes as S

ROOT = Path(__file__).resolve().parents[1]
CASES = ((30.0, 0.3), (30.0, 0.7))


def key(r: dict) -> tuple:
    return (r["engine"], r["shape"], r["size"], r["material"], r["contact"], r["n_grid"], r["theta"], r["mu"])


def run(a) -> list:
    log = Path(a.log)
    done = {key(json.loads(line)): json.loads(line) for line in log.read_text().splitlines()} if log.exists() else {}
    for eng in a.engines:
        for shape in a.shapes:
            for size in (a.sizes or S.sizes(shape)):
                for mat in a.materials:
                    for contact in a.contacts:
                        for n in a.grids:
                            for theta, mu in CASES:
                                r = dict(engine=eng, shape=shape, size=size, material=mat, contact=contact, n_grid=n,
                                         theta=theta, mu=mu)
                                if key(r) in done:
                                    continue
                                t0 = time.time()
                                f = S.measure(eng, shape, size, mat, contact, n, theta, mu)
                                r.update(figure=f if math.isfinite(f) else None, seconds=round(time.time() - t0, 1),
                                         tip=round(S.tip_margin(shape, theta, mu, size), 3),
                                         points=len(S.shape_points(shape, size, n)[0]),
                                         problem=S.problem(theta, mu, f, a.tol))
                                done[key(r)] = r
                                with log.open("a") as fh:
                                    fh.write(json.dumps(r) + "\n")
                                print(json.dumps(r), flush=True)
    return list(done.values())


def cell(rs: list) -> str:
    """One table cell: the figure of each engine (taichi_mpm / warp_mpm), '!' where the check fails."""
    out = []
    for r in sorted(rs, key=lambda r: r["engine"]):
        f = r["figure"]
        if f is None:
            out.append("diverged!")
        elif S.slides(r["theta"], r["mu"]):
            out.append(f"{100 * (f / S.closed_form(r['theta'], r['mu']) - 1):+.2f} %" + ("!" if r["problem"] else ""))
        else:
            out.append(f"{f:.3f} mm" + ("!" if r["problem"] else ""))
    return " / ".join(out)


def report(rows: list, tol: float) -> str:
    lines = ["# Slides and sticks over a family of shapes (issue 67, round 51)", "",
             "`benchmarks/slide_shapes.py`: per case taichi_mpm / warp_mpm. Slide (30 deg, mu 0.3): the acceleration's",
             f"error against g (sin - mu cos) = {S.closed_form(30, 0.3):.4f} m/s^2; stick (30 deg, mu 0.7): the",
             "centroid's travel in 1 s after a 0.1 s settle. `!`: fails the two-sided check "
             f"({100 * tol:g} %, 1 mm). tip: (h / w) max(tan theta, mu), under 1: it cannot tip.", ""]
    groups = {}
    for r in rows:
        groups.setdefault((r["shape"], r["size"], r["n_grid"]), []).append(r)
    head = "| shape | size | n_grid | points | tip | " + " | ".join(
        f"{m} {c} {w}" for m in S.MATERIALS for c in ("particle", "grid") for w in ("slide", "stick")) + " |"
    lines += [head, "|" + "---|" * (head.count("|") - 1)]
    for (shape, size, n), rs in sorted(groups.items(), key=lambda kv: (list(S.SHAPES).index(kv[0][0]), kv[0][1:])):
        cells = []
        for m in S.MATERIALS:
            for c in ("particle", "grid"):
                for case in CASES:
                    sel = [r for r in rs if r["material"] == m and r["contact"] == c and (r["theta"], r["mu"]) == case]
                    cells.append(cell(sel) if sel else "")
        pts = rs[0]["points"]
        tip = max(r["tip"] for r in rs)
        lines.append(f"| {shape} | {size:g} | {n} | {pts} | {tip:.2f} | " + " | ".join(cells) + " |")
    fails = [r for r in rows if r["problem"]]
    lines += ["", f"{len(rows)} cases, {len(fails)} fail the check."]
    return "\n".join(lines) + "\n"


def sink(engines) -> None:
    """The ``--sink`` lines (module docstring)."""
    import numpy as np

    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    bodies = {"slab 1 layer": (0.12, 0.12, 0.0125), "slab 2 layers": (0.12, 0.12, 0.025),
              "slab 4 layers": (0.12, 0.12, 0.05), "cube 7.5 cm": (0.075, 0.075, 0.075)}
    for eng in engines:
        for name, dims in bodies.items():
            S.SHAPES["_sink"] = ("box", dims)
            for mat in S.MATERIALS:
                s = S.shape_setup("_sink", 1.0, mat, "grid", 24, 0.0, 0.7)
                e = build_engine(get_engine(eng), s)
                z0 = float(np.asarray(s.x, np.float64)[:, 2].mean())
                for _ in range(round(1.1 * S.FPS)):
                    e.step_frame()
                x = e.positions().astype(np.float64)
                drop, low = z0 - float(x[:, 2].mean()), float(x[:, 2].min()) - S.GROUND
                print(f"{eng} {name} {mat}: centroid drop {1000 * drop:.3f} mm, lowest point "
                      f"{1000 * low:+.2f} mm over the plane", flush=True)
    del S.SHAPES["_sink"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--shapes", nargs="+", default=list(S.SHAPES))
    ap.add_argument("--sizes", type=float, nargs="+", default=None)
    ap.add_argument("--materials", nargs="+", default=list(S.MATERIALS))
    ap.add_argument("--contacts", nargs="+", default=["particle", "grid"])
    ap.add_argument("--grids", type=int, nargs="+", default=[24, 32])
    ap.add_argument("--tol", type=float, default=0.025)
    ap.add_argument("--log", default="/tmp/slideshapes/family.jsonl")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--sink", action="store_true")
    a = ap.parse_args()
    if a.sink:
        return sink(a.engines)
    if a.report_only:
        rows = [json.loads(line) for line in Path(a.log).read_text().splitlines()]
    else:
        rows = run(a)
    res = ROOT / "benchmarks" / "results"
    (res / "slide_shapes.json").write_text(json.dumps(rows, indent=1) + "\n")
    (res / "slide_shapes.md").write_text(report(rows, a.tol))


if __name__ == "__main__":
    main()
