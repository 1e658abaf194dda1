"""The porcelain cup of ``examples/cup_drop.toml`` (issue 66 item 5; ``docs/fracture.md`` "Stiff brittle bodies:
fragments"): ``gasp simulate``'s wall time to its last frame, the break (frame, approach speed, plane-wave stress,
Grady's size, fragments and their masses), the pieces, the lowest point, the total energy per frame (kinetic from the
frames' differences at mid-frame, potential over the ground) against the start's, and, at the last frame, each piece
of 5 % or more of the mass rendered alone from its crack side: the share of its silhouette below alpha 0.9 with and
without the crack faces (``benchmarks/crack_faces.py``'s measure: CPU renderer, 480 x 480), the silhouette the
projection of the piece's geometry (``benchmarks/piece_silhouette.py``) and, as before, the footprint of its intact
fill; and the opaque pixels beyond the geometry.

Run: ``python benchmarks/cup_drop.py [--engine taichi_mpm] [--speed 4.43] [--frames 20] [--stills]``; results in
``benchmarks/results/cup_drop_<engine>_<speed>.json`` and ``.md``; ``--stills`` renders the run at its break, halfway
and its last frame into ``docs/cup_drop_<speed>_<frame>.png`` (``gasp render``'s CPU renderer, its default camera
following the cup), the same frames with each piece in its own colour (``docs/cup_drop_<speed>_pieces_<frame>.png``)
the largest piece from its crack side without and with the crack faces (``docs/cup_drop_<speed>_without.png``,
``_with.png``) and each measured piece from its crack side with the pixels of its geometric silhouette below alpha 0.9
in red and the opaque ones beyond it in blue (``docs/cup_drop_<speed>_alpha_rim.png``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))


def run(engine: str, speed: float, frames: int, out: Path) -> dict:
    """``gasp simulate`` of the example at ``speed`` on ``engine`` into ``out``; the frames' points are recorded
    through :func:`gasp_core.run.fragment_run.frames`. Returns the figures and the points."""
    from gasp_core.run import fragment_run
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    text = (ROOT / "examples" / "cup_drop.toml").read_text()
    text = text.replace('name = "taichi_mpm"', f'name = "{engine}"')
    text = text.replace("velocity = [0.0, 0.0, -4.43]", f"velocity = [0.0, 0.0, {-speed}]")
    text = text.replace("n_frames = 20", f"n_frames = {frames}")
    text = text.replace('"data/cup_mesh.ply"', f'"{(ROOT / "examples" / "data" / "cup_mesh.ply").as_posix()}"')
    scene_file = out.parent / f"{out.name}.toml"
    scene_file.write_text(text)
    real, seen = fragment_run.frames, {}

    def recording(info, setup, stats, *a, **k):
        tracker = k.get("tracker", a[5] if len(a) > 5 else None)
        seen.update(setup=setup, stats=stats, xs=[setup.x.copy()], tracker=tracker)
        for rec in real(info, setup, stats, *a, **k):
            seen["xs"].append(rec.x.copy())
            yield rec
    fragment_run.frames = recording
    try:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scene(load_scene(scene_file), out, quiet=True, overwrite=True)
        wall = time.perf_counter() - t0
    finally:
        fragment_run.frames = real
    return {"wall_s": wall, **seen}


def figures(res: dict) -> dict:
    """The break's record, the pieces, the lowest point and the energies of a :func:`run`."""
    from test_cup_drop import energies
    setup, xs, stats = res["setup"], res["xs"], res["stats"]
    e = energies(setup, xs)
    rec = dict(stats.fragments[0]) if stats.fragments else {}
    return {"wall_s": res["wall_s"], "break": rec, "mass_kg": float(setup.p_mass.sum()),
            "lowest_mm": 1e3 * min(float(x[:, 2].min()) for x in xs), "energy_J": e.tolist(),
            "lowest_per_frame_mm": [1e3 * float(x[:, 2].min()) for x in xs],
            "energy_max_over_start": float(e[1:].max() / e[0]), "energy_last_over_start": float(e[-1] / e[0])}


def alpha_measure(res: dict, engine: str, stills_stem: str | None = None) -> list[dict]:
    """Each piece of 5 % or more at the last frame, from its crack side (``benchmarks/crack_faces.py``); with
    ``stills_stem``, that module's two stills (the whole break, the largest piece from its crack side; without and
    with the crack faces) and one still per frame of :func:`piece_frames` with each piece its own colour, into
    ``docs/<stills_stem>_*.png``."""
    import crack_faces as cf
    import piece_silhouette as ps
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.render.builtin import CpuRenderer
    from gasp_core.scene.spec import load_scene
    stats = res["stats"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(load_scene(res["scene_file"]), engine=engine)
    import gasp_core.run.pieces as pieces_mod
    x = res["xs"][-1]
    d = stats.damage if stats.damage is not None else np.zeros(len(x))
    real_tracker = pieces_mod.PieceTracker
    pieces_mod.PieceTracker = lambda *a, **k: res["tracker"]   # the run's: its pieces are the fragments
    try:
        parts = cf.scene_parts(prep, x, d)
        render = CpuRenderer(jit=True)
        geo = ps.object_geometry(prep.setup, prep.objects[0])
        rows = cf.measure_pieces(parts, x, d, render, faces="fill", geometry=geo)
        if stills_stem:
            cf.stills(parts, x, d, render, ROOT / "docs", stem=stills_stem)
            rim_still(cf, parts, geo, x, rows, render, ROOT / "docs" / f"{stills_stem}_alpha_rim.png")
            k0 = stats.fragments[0]["frame"] + 1 if stats.fragments else 1
            for f in (k0, (k0 + len(res["xs"]) - 1) // 2, len(res["xs"]) - 1):
                piece_still(cf, cf.scene_parts(prep, res["xs"][f], d), render,
                            ROOT / "docs" / f"{stills_stem}_pieces_{f:02d}.png")
    finally:
        pieces_mod.PieceTracker = real_tracker
    return [{k: v for k, v in r.items() if k not in ("ms", "cam")} for r in rows]


def rim_still(cf, parts, geo, x, rows, render, path: Path) -> None:
    """Each measured piece with its crack faces from its camera, side by side: grey as rendered (alpha over
    white), the pixels of its geometric silhouette below alpha 0.9 red, those at 0.9 or more outside it blue."""
    import imageio.v3 as iio
    imgs = []
    for r in rows:
        p, cam = r["piece"], r["cam"]
        shown = parts["vis"] & (parts["crack_piece"] == p)
        surf = cf.subset(parts["surf"], parts["surf_piece"] == p)
        alpha = render(type(surf).concat([surf, cf.subset(parts["crack"], shown)]), cam)[1]
        sil = geo.silhouette(cam, x, parts["labels"], p)
        img = np.repeat((1.0 - 0.6 * alpha)[..., None], 3, axis=2)
        img[sil & (alpha < cf.ALPHA)] = [1.0, 0.0, 0.0]
        img[~sil & (alpha >= cf.ALPHA)] = [0.3, 0.3, 1.0]
        imgs.append(img)
    iio.imwrite(path, (np.clip(np.concatenate(imgs, 1), 0, 1) * 255).astype(np.uint8))


#: Colours of the pieces in :func:`piece_still` (largest first).
PALETTE = np.array([[0.85, 0.3, 0.25], [0.25, 0.55, 0.85], [0.3, 0.7, 0.35], [0.9, 0.7, 0.2], [0.6, 0.35, 0.75],
                    [0.2, 0.75, 0.75], [0.85, 0.5, 0.65], [0.5, 0.5, 0.5]], np.float32)


def piece_still(cf, parts, render, path: Path, size: int = 480) -> None:
    """The break from above and beside, each piece's Gaussians and shown crack faces in its own colour."""
    import imageio.v3 as iio
    from gasp_core.gs.camera import auto_camera
    rank = np.argsort(np.argsort(-np.bincount(parts["labels"], weights=parts["mass"])))
    surf = cf.subset(parts["surf"], np.ones(len(parts["surf_piece"]), bool))
    surf.rgb = PALETTE[np.minimum(rank[parts["surf_piece"]], len(PALETTE) - 1)]
    crack = cf.subset(parts["crack"], parts["vis"])
    crack.rgb = PALETTE[np.minimum(rank[parts["crack_piece"][parts["vis"]]], len(PALETTE) - 1)]
    both = type(surf).concat([surf, crack])
    lo, hi = both.means.min(0), both.means.max(0)
    cam = auto_camera(lo, hi, size, size, 30.0, azimuth_deg=-60.0, elevation_deg=35.0)
    img = render(both, cam, background=np.ones(3))[0]
    iio.imwrite(path, (np.clip(img, 0, 1) * 255).astype(np.uint8))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--speed", type=float, default=4.43)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--stills", action="store_true")
    ap.add_argument("--rule", choices=["map", "hold", "trim", "pull", "gap"], default="map",
                    help="the Gaussians' drawing rule the silhouettes are measured with (crack_faces.RULE; map: as "
                         "before round 31)")
    a = ap.parse_args()
    import crack_faces
    crack_faces.RULE = None if a.rule == "map" else a.rule
    work = Path(os.environ.get("TMPDIR", "/tmp")) / "gasp_cup_drop"
    work.mkdir(parents=True, exist_ok=True)
    out = work / f"{a.engine}_{a.speed:g}"
    res = run(a.engine, a.speed, a.frames, out)
    res["scene_file"] = work / f"{out.name}.toml"
    fig = figures(res)
    fig["pieces_alpha"] = alpha_measure(res, a.engine, f"cup_drop_{a.speed:g}" if a.stills else None)
    fig.update(engine=a.engine, speed=a.speed, frames=a.frames, load=os.getloadavg()[0])
    fig["rule"] = a.rule
    tail = "" if a.rule == "map" else f"_{a.rule}"
    stem = ROOT / "benchmarks" / "results" / f"cup_drop_{a.engine}_{a.speed:g}{tail}"
    Path(f"{stem}.json").write_text(json.dumps(fig, indent=1, default=float))
    b = fig["break"]
    lines = [f"# The cup drop: {a.engine}, {a.speed:g} m/s, {a.frames} frames (load {fig['load']:.1f}; the Gaussians "
             f"drawn with the rule {a.rule})", "",
             f"gasp simulate to the last frame: {fig['wall_s']:.1f} s", "",
             f"break after frame {b.get('frame')}: approach {b.get('impact_speed', 0):.2f} m/s, stress "
             f"{b.get('stress', 0) / 1e6:.1f} MPa, Grady size {1e3 * b.get('size', 0):.1f} mm, "
             f"{b.get('fragments')} fragments, masses (g) {[round(1e3 * m, 1) for m in b.get('fragment_mass', [])]}",
             "", f"energy: start {fig['energy_J'][0]:.3f} J, largest later {fig['energy_max_over_start']:.4f} of it, "
             f"last {fig['energy_last_over_start']:.4f}; lowest point {fig['lowest_mm']:.2f} mm", "",
             "Each piece of 5 % or more from its crack side: the share of its silhouette below alpha 0.9, the "
             "silhouette its geometry (`benchmarks/piece_silhouette.py`) and, as before round 31, the fill's "
             "footprint (discs of 0.75 spacing); and the pixels at alpha 0.9 or more outside the geometry, over its "
             "silhouette (what the splats show beyond the piece).", "",
             "| piece | mass (g) | faces shown | geometry: without faces | with faces | footprint: without | with "
             "| beyond the geometry: without | with |", "|---|---|---|---|---|---|---|---|---|"]
    pct = lambda r, k: f"{100 * r.get(k, float('nan')):.2f} %"   # noqa: E731
    lines += [f"| {r['piece']} | {1e3 * r['mass']:.1f} | {r['fill_n']} | {pct(r, 'geo_without')} | "
              f"{pct(r, 'geo_fill')} | {pct(r, 'without')} | {pct(r, 'fill')} | {pct(r, 'over_without')} | "
              f"{pct(r, 'over_fill')} |" for r in fig["pieces_alpha"]]
    Path(f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    if a.stills:
        stills(out, b.get("frame", 0) + 1, a.frames, a.speed)


def stills(run_dir: Path, first: int, last: int, speed: float) -> None:
    """PNGs of the run at ``first`` (just after the break), halfway and ``last`` into ``docs/``."""
    import shutil
    import subprocess
    tmp = run_dir.parent / f"{run_dir.name}_png"
    shutil.rmtree(tmp, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "gasp_core", "render", str(run_dir), "-o", str(tmp), "-q"], check=True)
    for f in (first, (first + last) // 2, last):
        shutil.copy(tmp / f"frame_{f:04d}.png", ROOT / "docs" / f"cup_drop_{speed:g}_{f:02d}.png")


if __name__ == "__main__":
    main()
