"""Does the figure stand at the E the stand estimate names, and fall well below it (issue 38, item 6)?

The standing figure of ``tests/test_stand.py`` (0.25 m: a box on two legs 4 cm thick, flat Gaussians on its faces
filled by the pipeline, jelly rho 1000, nu 0.3, friction 0.8, warp_mpm, n_grid 32 so dx = 1.59 cm and the legs are
2.5 cells thick) through ``gasp simulate``'s pipeline for 30 frames at multiples of the ``E_crit`` that
``gasp simulate`` warns with. Per frame: the lean (degrees: the top tenth's centroid against the bottom tenth's,
from the vertical) and the height (the top tenth's centroid over its start).

Run: ``python benchmarks/stand_figure.py OUTDIR [--factors 1,0.2,0.5] [--surface auto|passive] [--sleep]
[--shear S] [--frames N] [--out NAME.md]``; writes ``benchmarks/results/NAME.md`` (default ``stand_figure.md``).
"""
import argparse
import pathlib
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
import test_stand as ts  # noqa: E402

from gasp_core.cli.info import info  # noqa: E402
from gasp_core.run.pipeline import simulate_scene  # noqa: E402
from gasp_core.scene.spec import load_scene  # noqa: E402


def run(ply, E: float, tmp: pathlib.Path, a) -> list[tuple[int, float, float]]:
    """The figure at ``E`` (Pa): per frame (frame, lean, height ratio)."""
    toml = ts.scene_file(ply, E, tmp, f"E{E:.0f}_{a.surface}_{a.sleep}", a.surface, sleep=a.sleep, n_frames=a.frames)
    rows, x0 = [], []

    def on_frame(k, gs):
        m = gs[0].means.astype(np.float64)
        if not x0:
            x0.append(m.copy())
        rows.append((k, *ts.lean_and_height(m, x0[0])))
        print(E, *rows[-1], flush=True)

    try:
        simulate_scene(load_scene(toml), tmp / f"run_{a.surface}_{E:.0f}_{a.sleep}", quiet=True, on_frame=on_frame)
    except Exception as e:   # a figure that falls out of the domain: keep its frames
        print(f"stopped: {type(e).__name__}: {str(e)[:200]}", flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("outdir", type=pathlib.Path)
    ap.add_argument("--factors", default="1,0.2,0.5", help="multiples of E_crit, comma-separated")
    ap.add_argument("--surface", default="auto")
    ap.add_argument("--sleep", action="store_true", help="let a body at rest sleep (the default of gasp simulate)")
    ap.add_argument("--shear", type=float, default=0.0, help="imperfection: y += shear z")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--out", default="stand_figure.md", help="file under benchmarks/results")
    a = ap.parse_args()
    tmp = a.outdir
    tmp.mkdir(parents=True, exist_ok=True)
    factors = [float(f) for f in a.factors.split(",")]
    ply = tmp / f"figure_{a.shear:g}.ply"
    if not ply.exists():
        ts.figure(ply, a.shear)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        ts.prepared(ply, 1.0, tmp, a.surface)
    line = [str(w.message) for w in got if "carry its own weight" in str(w.message)][0]
    E_crit = float(line.split("needs E of about ")[1].split(" Pa")[0])
    d = info(ply, rho=1000.0, n_grid=32)
    out = [f"# The standing figure at its estimated E_crit (`python benchmarks/stand_figure.py OUTDIR "
           f"{' '.join(sys.argv[2:])}`)", "",
           f"Figure of `tests/test_stand.py` (shear {a.shear:g}: initial lean {np.degrees(np.arctan(a.shear)):.2f} deg), "
           f"{a.surface} surface, warp_mpm (CPU), n_grid 32, {a.frames} frames of 1/30 s, the default contact, "
           f"sleep = {str(a.sleep).lower()}" + ("" if a.sleep else " (a resting body is not frozen: a slow lean shows)")
           + ". Lean: the top tenth's centroid against the bottom tenth's, from the vertical; height: the top tenth's "
           "centroid over its start.", "",
           f"`gasp simulate` warns: {line}", "",
           f"`gasp info --rho 1000` (n_grid 32): stand_E_crit_Pa = {d['stand_E_crit_Pa']:.3g} "
           f"(stand_E_static_Pa {d['stand_E_static_Pa']:.3g})", ""]
    for f in factors:
        t0 = time.perf_counter()
        rows = run(ply, f * E_crit, tmp, a)
        load = pathlib.Path("/proc/loadavg").read_text().split()[:3]
        out += [f"## E = {f:g} x E_crit = {f * E_crit:.3g} Pa ({time.perf_counter() - t0:.0f} s, load {' '.join(load)})",
                "", "| frame | lean (deg) | height / start |", "|---|---|---|"]
        out += [f"| {k} | {lean:.4f} | {h:.4f} |" for k, lean, h in rows if k % 10 == 0 or k == rows[-1][0]]
        out.append("")
    (pathlib.Path(__file__).parent / "results" / a.out).write_text("\n".join(out))


if __name__ == "__main__":
    main()
