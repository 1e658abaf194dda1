"""A tear that stays closed until it parts (issue 52, item 3; docs/fracture.md, "Clamped triangles split"): the
share of a tearing neck's silhouette where the background shows through (alpha below 0.9), with the alpha rule
alone and with the clamped triangles split into sub-triangle Gaussians (:mod:`gasp_core.maps.split`), the
Gaussians the split adds and the render time.

The scene: the T rod of ``tests/test_brittle.py`` (a 0.08 m square neck 0.3 m long under a 0.2 m head held over its
top half; 640 flat Gaussians on 2 cm tiles, n_grid 29) as **plasticine** hanging under its own weight,
``yield_stress = 0.8 rho g L`` (2354 Pa against ``rho g L`` = 2943 Pa: the neck's top fifth over its yield; at 0.92
it parted at the held region's edge until the held boxes' ghost nodes, and now holds), ``softening = 3``: it necks and
parts in the neck at frame 24 of 0.02 s (taichi_mpm, f32, one thread). Plasticine has no damage, so there are no
pieces: every clamped triangle is split (:func:`gasp_core.run.frames.rebuild`), the sub-Gaussians over a gap dropped
where no material is left under them (:func:`gasp_core.maps.split.near_material`).

Where it parts: the fill points linked within 3 fill spacings at their current positions (about 1.9 ``dx``: the
grid still couples points closer than that) form two groups; the **neck window** is the fill points within
0.05 m (at rest) of the plane between them, and its silhouette the footprint of those points (discs of 0.75 fill
spacings, as ``benchmarks/crack_faces.py``), seen from the side (-y) on a camera fitted to the window (CPU renderer,
480 x 480, DC colour). Each frame from 16 to the end: the share of that silhouette below alpha 0.9 with no alpha
rule (the stretched Gaussians, the reference), with the rule alone (today's output), and with the split; the
Gaussians added; and, at the last frame before it parts, the render time of the whole rod with and without them
(median of 15, alternating).

``--donut``: the cost on a real scan, the donut shatter (``examples/donut_shatter.toml``, taichi_mpm) at frame 4 with
its pieces: the Gaussians the split adds, the rebuild's time, and the render time of the whole donut (480 x 480, its
default-like camera, DC colour, median of 5 alternating), with and without them; to
``benchmarks/results/tear_split_donut.md``.

Run: ``python benchmarks/tear_split.py [--frames 40]``; the table to stdout and
``benchmarks/results/tear_split.md``; stills ``docs/fracture_tear_split.png`` (the neck without and with the split, the
frame before it parts and 3 frames after). The engine is stepped directly (no ``gasp simulate``). The rod creeps
about 1.2 mm (0.03 dx) a frame, under both of sleep's displacement bounds: the pipeline's default ``sleep`` put it to
sleep after frame 5, before it tore, until a growing plastic strain kept it awake (``gasp_core.seam.sleep.FLOW_TOL``;
``tests/test_sleep_creep.py``: through ``gasp simulate`` it parts at frame 23 on both engines).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from crack_faces import silhouette  # noqa: E402  (benchmarks/crack_faces.py: the same footprint measure)

ROOT = Path(__file__).resolve().parents[1]
ALPHA = 0.9
YIELD_FRACTION, SOFTENING = 0.8, 3.0
LINK = 3.0          # fill spacings: the groups' link at current positions
WINDOW = 0.05       # m, rest: the neck window's half height around the parting plane


def scene(folder: Path, n_frames: int) -> Path:
    """The plasticine T rod's PLY and scene file in ``folder``; the scene's path."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_brittle as tb
    from gasp_core.gs.io import write_gaussians
    write_gaussians(folder / "rod.ply", tb.t_rod(), overwrite=True)
    text = tb.rod_scene_text("taichi_mpm", folder / "rod.ply", 1.0, n_frames)
    text = text.replace('name = "brittle"', 'name = "plasticine"').replace(
        "tensile_strength = 1.0\nfracture_energy = 5.0",
        f"yield_stress = {YIELD_FRACTION * tb.RHO_G_L}\nsoftening = {SOFTENING}")
    (folder / "rod.toml").write_text(text)
    return folder / "rod.toml"


def groups(xf: np.ndarray, h: float) -> np.ndarray:
    """Connected groups of the fill points ``xf`` (k, 3) linked closer than ``LINK h``, shape (k,), int."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    pairs = cKDTree(xf).query_pairs(LINK * h, output_type="ndarray")
    n = len(xf)
    return connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)),
                                directed=False)[1]


def side_camera(pts, size=480):
    from gasp_core.gs.camera import Camera, fit_to_box
    lo, hi = pts.min(0), pts.max(0)
    c = 0.5 * (lo + hi)
    cam = Camera(c + np.array([0.0, -4.0, 0.0]), c, 30.0, size, size, near=1e-3)
    return fit_to_box(cam, lo - 0.01, hi + 0.01, margin=1.15)


def splats(o, g_obj, g_split):
    """World splats of the object's rows, and with its sub-Gaussians appended (None: the rows alone)."""
    from gasp_core.gs.splat_numpy import Splats, splats_from_gaussians
    pl = o.placement
    base = splats_from_gaussians(g_obj, pl.R, pl.scale, pl.t)
    base.sh = base.sh_frames = None
    if g_split is None:
        return base, base
    sub = splats_from_gaussians(g_split, pl.R, pl.scale, pl.t)
    sub.sh = sub.sh_frames = None
    return base, Splats.concat([base, sub])


def donut(frames: int = 4) -> str:
    """The split's cost on the donut shatter at ``frames`` (see the module's text); the results' text."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import crack_faces as cf
    from gasp_core.render.builtin import CpuRenderer
    from gasp_core.gs.camera import auto_camera
    from gasp_core.run.frames import rebuild, split_context
    from gasp_core.run.pieces import PieceTracker
    render = CpuRenderer(jit=True)
    prep, x, d = cf.run_to("taichi_mpm", frames)
    s, o = prep.setup, prep.objects[0]
    lab = PieceTracker(s.x, s.body_id, s.p_mass, s.p_vol).labels(x, d)
    ctx = split_context(o, s)
    t0 = time.perf_counter()
    g0, _, c0 = rebuild(o, x, o.rot_rest, labels=lab)
    t1 = time.perf_counter()
    g, _, c = rebuild(o, x, o.rot_rest, labels=lab, split=ctx)
    t2 = time.perf_counter()
    base, both = splats(o, g, c["split_gaussians"])
    cam = auto_camera(base.means.min(0), base.means.max(0), 480, 480, 30.0, azimuth_deg=-60.0, elevation_deg=35.0)
    render(base, cam)   # compiled
    tb_, tw = [], []
    for _ in range(5):
        for sp, acc in ((base, tb_), (both, tw)):
            t3 = time.perf_counter()
            render(sp, cam)
            acc.append(time.perf_counter() - t3)
    a, b = float(np.median(tb_)), float(np.median(tw))
    return (f"# The split's cost on the donut shatter (`benchmarks/tear_split.py --donut`, taichi_mpm, "
            f"frame {frames})\n\n"
            f"{o.gaussians.n} Gaussians, {c['clamped']} scales clamped, {c['straddling']} Gaussians straddling a crack "
            f"(not split); the split adds **{c['split']}** sub-Gaussians ({100 * c['split'] / o.gaussians.n:+.0f} %). "
            f"Rebuild {1e3 * (t1 - t0):.0f} ms without, {1e3 * (t2 - t1):.0f} ms with the split. Render (the whole "
            f"donut, 480 x 480, CPU renderer with numba, median of 5 alternating, 2 cores shared with another "
            f"engineer's work): {1e3 * a:.0f} ms without, {1e3 * b:.0f} ms with ({100 * (b / a - 1):+.0f} %).\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--first", type=int, default=16, help="the first frame measured")
    ap.add_argument("--donut", action="store_true", help="the cost on the donut shatter instead (see the text)")
    ap.add_argument("--gap", type=float, default=None, help="gasp_core.maps.split.GAP (fill spacings; default 0.5)")
    ap.add_argument("--out", default="tear_split", help="the results file's stem (benchmarks/results/STEM.md)")
    ap.add_argument("--still", default=str(ROOT / "docs" / "fracture_tear_split.png"), help="the stills' PNG")
    args = ap.parse_args(argv)
    import gasp_core.maps.split as split_mod
    if args.gap is not None:
        split_mod.GAP = args.gap
    if args.donut:
        text = donut()
        print(text)
        (ROOT / "benchmarks" / "results" / "tear_split_donut.md").write_text(text)
        return 0
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.render.builtin import CpuRenderer
    from gasp_core.run.frames import rebuild, split_context
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    render = CpuRenderer(jit=True)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(load_scene(scene(Path(tmp), args.frames)), engine="taichi_mpm")
        e = build_engine(prep.info, prep.setup)
    s, o = prep.setup, prep.objects[0]
    free = dataclasses.replace(o, surface=dataclasses.replace(o.surface, alpha=None))   # no alpha rule
    ctx = split_context(o, s)
    fill = np.arange(len(s.x))[o.fill_slice]
    h, x0f = ctx.h, s.x[fill]
    states, prev, prev_free = [], o.rot_rest, o.rot_rest
    t0 = time.perf_counter()
    for f in range(1, args.frames + 1):
        e.step_frame()
        x = np.asarray(e.positions(), np.float64)
        g, prev, c = rebuild(o, x, prev, split=ctx)
        gf, prev_free, _ = rebuild(free, x, prev_free)
        lab = groups(x[fill], h)
        states.append((f, x, g, gf, c, lab))
    sim_s = time.perf_counter() - t0
    e.close()
    # where it parts: the first frame with two groups of 10 % of the fill or more; the plane between them (rest)
    parted = None
    for f, x, g, gf, c, lab in states:
        big = np.flatnonzero(np.bincount(lab) >= 0.1 * len(fill))
        if len(big) >= 2:
            parted = f
            low, up = sorted(big, key=lambda b: x0f[lab == b, 2].mean())[:2]
            plane = 0.5 * (x0f[lab == low, 2].max() + x0f[lab == up, 2].min())
            break
    if parted is None:
        print("the rod did not part in", args.frames, "frames")
        return 1
    window = np.abs(x0f[:, 2] - plane) <= WINDOW
    rows, timing, still = [], None, None
    for f, x, g, gf, c, lab in states:
        if f < args.first:
            continue
        pts = x[fill][window]
        cam = side_camera(pts)
        sil = silhouette(cam, pts, h)
        base, both = splats(o, g, c["split_gaussians"])
        free_sp, _ = splats(o, gf, None)
        share = [float(np.mean(render(sp, cam)[1][sil] < ALPHA)) for sp in (free_sp, base, both)]
        rows.append((f, c["clamped"], c["split"], *share))
        if f == parted - 1:
            t_base, t_both = [], []
            for _ in range(15):
                for sp, acc in ((base, t_base), (both, t_both)):
                    t1 = time.perf_counter()
                    render(sp, cam)
                    acc.append(time.perf_counter() - t1)
            timing = (base.n, both.n, float(np.median(t_base)), float(np.median(t_both)))
            still = [(cam, base, both)]
        if still is not None and f == parted + 3:   # after it parted: the gap must show
            still.append((cam, base, both))
    lines = [f"# A tear that stays closed until it parts (`benchmarks/tear_split.py`, taichi_mpm, f32)", "",
             f"The plasticine T rod (yield_stress {YIELD_FRACTION} rho g L = {YIELD_FRACTION * 2943.0:.0f} Pa, "
             f"softening {SOFTENING}), {args.frames} frames of 0.02 s simulated in {sim_s:.0f} s. It parts at frame "
             f"{parted} (two groups of fill points {LINK:g} fill spacings apart), the plane {plane - 0.45:.3f} m up "
             f"the 0.3 m neck (rest); the neck window: {int(window.sum())} of {len(fill)} fill points within "
             f"{WINDOW} m of it. Alpha rule 1.5 (the default); a sub-Gaussian drawn up to {split_mod.GAP:g} fill "
             f"spacing farther from the fill than at rest.", "",
             "| frame | clamped scales | sub-Gaussians added | alpha < 0.9, no alpha rule | the rule alone (before) | "
             "the rule and the split (now) |", "|---|---|---|---|---|---|"]
    for f, nc, ns, a, b, cc in rows:
        mark = " (parts)" if f == parted else (" (the frame before)" if f == parted - 1 else "")
        lines.append(f"| {f}{mark} | {nc} | {ns} | {100 * a:.1f} % | {100 * b:.1f} % | {100 * cc:.1f} % |")
    if timing is not None:
        n0, n1, tb_, tw = timing
        lines += ["", f"Render time at frame {parted - 1} (the whole rod, 480 x 480, CPU renderer with numba, median "
                  f"of 5, load from another engineer's work on the same 2 cores): {n0} Gaussians {1e3 * tb_:.1f} ms, "
                  f"{n1} with the split ({n1 - n0:+d}, {100 * (n1 / n0 - 1):+.0f} %) {1e3 * tw:.1f} ms "
                  f"({100 * (tw / tb_ - 1):+.0f} %)."]
    if still is not None:
        import imageio.v3 as iio
        rows_img = [np.concatenate([render(sp, cam, background=np.ones(3))[0] for sp in (base, both)], 1)
                    for cam, base, both in still]
        path = Path(args.still)
        iio.imwrite(path, (np.clip(np.concatenate(rows_img, 0), 0, 1) * 255).astype(np.uint8))
        lines += ["", f"Stills (the neck window; left the rule alone, right with the split; top frame {parted - 1}, "
                  f"the frame before it parts" + (f", bottom frame {parted + 3}, parted" if len(still) > 1 else "")
                  + f"): `{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}`"]
    text = "\n".join(lines) + "\n"
    print(text)
    (ROOT / "benchmarks" / "results" / f"{args.out}.md").write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
