"""Crack faces on the shattered donut (issue 52, item 3; docs/fracture.md, "Crack faces"): how much of each piece's
silhouette lets the background through (alpha below 0.9), seen from the side that faces its crack, with and without
the crack-face Gaussians of :mod:`gasp_core.maps.crack_faces`, and two stills of the whole break.

``examples/donut_shatter.toml`` is run ``--frames`` frames on the engine (default taichi_mpm, 4 frames); at the last
one every piece of at least 5 % of the donut's mass is rendered alone (CPU renderer, 480 x 480, DC colour) from a
camera on its crack side (the mean normal of its exposed faces), fitted to it. A piece's silhouette is the footprint
of its material: its intact fill points (``d < 0.9``), each a disc of 0.75 fill spacings (the surface Gaussians lie
around it; the broken points are the crack band between the pieces). Stills:
``docs/fracture_crack_without.png`` and ``docs/fracture_crack_with.png`` (the whole donut from the largest piece's
crack side).

``--scene rod``: the same on the T rod of ``tests/test_brittle.py`` hanging from its head at ``tensile_strength =
0.6 rho g L`` (it breaks in the upper half of its neck), 8 frames; stills ``docs/fracture_rod_without.png`` and
``docs/fracture_rod_with.png``.

``--faces both`` (or ``triangles``) measures the issue's second candidate beside the first on the same break, from the
same camera: Gaussians spawned on the crack faces from the split triangles (``benchmarks/studies/crack_triangles.py``:
measured here and rejected, so kept out of ``gasp_core``): the same share, the Gaussians each adds, and the render's
milliseconds (best of 5, each piece alone and the whole break); results in ``crack_faces_compare.md``
(``crack_faces_compare_rod.md``), a still ``docs/fracture_crack_triangles.png`` (none when no triangle is split).

Run: ``python benchmarks/crack_faces.py [--engine taichi_mpm] [--frames 4] [--scene donut|rod] [--faces
fill|triangles|both]``; the table goes to stdout and ``benchmarks/results/crack_faces.md`` (``crack_faces_rod.md``;
``--faces both``: ``crack_faces_compare[_rod].md``).
"""
from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ALPHA = 0.9
BIG = 0.05
BROKEN = 0.9            # gasp_core.run.pieces.BROKEN


def rod_scene(folder: Path, engine: str) -> Path:
    """The T rod of ``tests/test_brittle.py`` hanging from its head (held over its top half) at ``tensile_strength =
    0.6 rho g L``, where it breaks in the upper half of its neck: its PLY and scene file written into ``folder``;
    the scene's path."""
    import sys
    sys.path.insert(0, str(ROOT / "tests"))
    import test_brittle as tb   # the rod the brittle tests hang (tests/test_brittle.py: t_rod, rod_run)
    from gasp_core.gs.io import write_gaussians
    write_gaussians(folder / "rod.ply", tb.t_rod())
    (folder / "rod.toml").write_text(tb.rod_scene_text(engine, folder / "rod.ply", 0.6 * tb.RHO_G_L))
    return folder / "rod.toml"


def run_to(engine: str, frames: int, scene: Path = ROOT / "examples" / "donut_shatter.toml"):
    """``(prep, x, damage)`` of ``scene`` (default the donut shatter) after ``frames`` frames."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(load_scene(scene), engine=engine)
        e = build_engine(prep.info, prep.setup)
    for _ in range(frames):
        e.step_frame()
    x, d = np.asarray(e.positions(), np.float64), np.asarray(e.damage(), np.float64)
    e.close()
    return prep, x, d


#: The drawing rule of a broken body's Gaussians the measure renders: None the map with straddling Gaussians kept
#: whole (the rule before round 31, the figures of docs/fracture.md's tables), "hold" (round 31), "trim" (round 32, the trim rule) or
#: "pull" (round 32, the pull rule: the crack faces kept to their side too) or "gap" (round 32, the gap rule, what ``gasp simulate`` draws now:
#: kept to their side only where the pieces are apart, :class:`gasp_core.run.sides.PieceTree`);
#: ``benchmarks/cup_drop.py --rule`` sets it.
RULE = None


def scene_parts(prep, x, d):
    """Surface splats and their pieces, crack-face splats (all; visible ones opaque) and theirs, point labels."""
    from gasp_core.maps.crack_faces import build_crack_faces, crack_face_gaussians
    from gasp_core.gs.splat_numpy import Splats, splats_from_gaussians
    from gasp_core.run.frames import rebuild
    from gasp_core.run.pieces import PieceTracker
    from gasp_core.gs.ply import SH_C0
    s, o = prep.setup, prep.objects[0]
    tracker = PieceTracker(s.x, s.body_id, s.p_mass, s.p_vol)
    labels = tracker.labels(x, d)
    apart = None
    if RULE is not None:      # the run's drawing rule on top (gasp_core.run.apart, gasp_core.run.sides)
        from gasp_core.run.apart import REACH, PieceContext
        apart = PieceContext(s.p_mass, tracker.pieces, REACH * float(s.dx), s.x, True, RULE != "hold",
                             RULE in ("pull", "gap"), s.p_vol, float(s.dx) if RULE == "gap" else None)
    g = rebuild(o, x, o.rot_rest, labels=labels, apart=apart)[0]   # straddling Gaussians kept whole
    pl = o.placement
    surf = splats_from_gaussians(g, pl.R, pl.scale, pl.t)
    surf.sh = surf.sh_frames = None
    rows = np.arange(len(s.x))[o.fill_slice]
    h = float(np.max(s.p_vol[rows])) ** (1 / 3)
    dc = o.gaussians.sh_dc if o.moving is None else o.gaussians.sh_dc[o.moving]
    faces = build_crack_faces(s.x[rows], rows, tracker.pairs, o.surface.tri_rest[:, 0], dc, h, x_rest=s.x)
    means, rot, scales, vis = crack_face_gaussians(faces, x, labels, d)
    if RULE in ("pull", "gap"):   # the faces kept to their piece's side too (round 32, the pull rule, gasp_core.run.sides)
        vis = faces_to_side(s, rows, tracker.pieces, labels, x, means, rot, scales, vis)
    M = rot * scales[:, None, :]
    crack = Splats(means, M @ M.transpose(0, 2, 1), np.clip(0.5 + SH_C0 * faces.sh_dc, 0, 1).astype(np.float32),
                   np.where(vis, 0.99, 0.0).astype(np.float32))
    normals = rot[:, :, 0]
    # each Gaussian's piece, as the point labels (gaussian_pieces numbers them within the object; all rows move here)
    glab = labels[o.vertex_slice][o.surface.anchors()]
    # candidate B: Gaussians on the crack faces from the split triangles (benchmarks/studies/crack_triangles.py)
    import sys
    sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))
    from crack_triangles import build_split_triangles, split_triangle_faces
    t0 = time.perf_counter()
    tris = build_split_triangles(np.arange(len(s.x))[o.vertex_slice][o.surface.shape_rows()], s.x, dc, h)
    tb = split_triangle_faces(tris, x, labels)
    tri_s = time.perf_counter() - t0
    Mb = tb.rotations * tb.scales[:, None, :]
    tri = Splats(tb.means, Mb @ Mb.transpose(0, 2, 1), np.clip(0.5 + SH_C0 * tb.sh_dc, 0, 1).astype(np.float32),
                 np.full(tb.n, 0.99, np.float32))
    return dict(surf=surf, surf_piece=glab, crack=crack, vis=vis,
                crack_piece=labels[rows], normals=normals, labels=labels, mass=tracker.mass, h=h, o=o,
                tri=tri, tri_piece=tb.piece, tri_normals=tb.rotations[:, :, 0], tri_s=tri_s,
                n_split=int(len(np.unique(split_rows(tris, labels)))))


def faces_to_side(s, rows, pieces, labels, x, means, rot, scales, vis):
    """The crack faces ``vis`` (shown) kept on their piece's side (with :data:`RULE` "gap" only where the pieces
    are apart), ``scales`` trimmed in place, as ``gasp simulate`` draws them
    (:func:`gasp_core.run.sides.keep_faces_to_side`); the faces shown now."""
    from gasp_core.run.apart import REACH, TIPS
    from gasp_core.run.sides import PieceTree, keep_faces_to_side, opening
    lab = np.asarray(labels)
    pts = rows[np.asarray(s.p_mass)[rows] > 0]
    if pieces is not None:
        pts = pts[np.asarray(pieces, bool)[lab[pts]]]
    if len(pts) == 0:
        return vis
    tree = PieceTree(x[pts], lab[pts], opening(s.p_vol[pts], float(s.dx)) if RULE == "gap" else None)
    return keep_faces_to_side(means, rot, scales, vis, lab[rows], tree, lab[pts], REACH * float(s.dx), TIPS)[0]


def split_rows(tris, labels):
    """The split triangles (rows of ``tris.rows``) at the point ``labels``."""
    lab = np.asarray(labels)[tris.rows]
    return np.flatnonzero((lab != lab[:, :1]).any(axis=1))


def subset(sp, keep):
    from gasp_core.gs.splat_numpy import Splats
    return Splats(sp.means[keep], sp.covs[keep], sp.rgb[keep], sp.opacities[keep])


def silhouette(cam, pts, h):
    """Pixels within 0.75 h (projected at the points' mean depth) of a point of ``pts``, shape (H, W), bool."""
    from scipy.ndimage import binary_dilation
    uv, z = cam.project_points(pts)
    mask = np.zeros((cam.height, cam.width), bool)
    i = np.floor(uv).astype(int)
    ok = (z > cam.near) & (i[:, 0] >= 0) & (i[:, 0] < cam.width) & (i[:, 1] >= 0) & (i[:, 1] < cam.height)
    mask[i[ok, 1], i[ok, 0]] = True
    r = max(1, int(round(0.75 * h * cam.focal_px / float(np.mean(z[ok])))))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    return binary_dilation(mask, structure=xx ** 2 + yy ** 2 <= r * r)


def crack_camera(centre, direction, lo, hi, size):
    from gasp_core.gs.camera import Camera, fit_to_box
    direction = direction / np.linalg.norm(direction)
    if abs(direction[2]) > 0.97:       # straight down or up: lean it so the look-at frame is defined
        direction = direction + np.array([0.3, 0.0, 0.0])
        direction /= np.linalg.norm(direction)
    dist = 4.0 * float(np.linalg.norm(hi - lo))
    cam = Camera(centre + dist * direction, centre, 30.0, size, size, near=1e-3)
    return fit_to_box(cam, lo, hi, margin=1.15)


def at_rest_share(rest, sel, direction, render, size=480) -> float:
    """The share below alpha 0.9 of the same material points ``sel`` (setup rows) in the unbroken body at frame 0
    (``rest``: ``(parts, x)`` of :func:`scene_parts` there), seen from the same side ``direction`` with the whole
    body's surface: what the Gaussians' own edges leave under 0.9 with no crack (the floor of the measure)."""
    parts0, x0 = rest
    pts = x0[sel]
    cam = crack_camera(pts.mean(0), direction, pts.min(0), pts.max(0), size)
    _, alpha = render(parts0["surf"], cam)
    return float(np.mean(alpha[silhouette(cam, pts, parts0["h"])] < ALPHA))


def measure_pieces(parts, x, d, render, size=480, rest=None, faces="fill", geometry=None):
    """One dict per piece of at least 5 % of the mass: ``piece``, ``mass`` (kg), ``without`` (the share of its
    silhouette with alpha < 0.9 without crack faces), and per candidate (``faces``: ``fill``, ``triangles`` or
    ``both``) ``fill_n`` / ``fill`` (the first: its shown faces, the share) and ``tri_n`` / ``tri`` (the second),
    ``floor`` (the same material unbroken at frame 0 from the same side: :func:`at_rest_share`, with ``rest``), and
    ``ms`` (the render's milliseconds, best of 5: ``none``, ``fill``, ``tri``). The camera is the same for every
    candidate: on the piece's crack side, the mean normal of the first candidate's shown faces there (else the
    second's). With ``geometry`` (a :class:`piece_silhouette.PieceGeometry`), each share is also read on the piece's
    geometric silhouette (``geo_without``, ``geo_fill``, ``geo_tri``) and ``over_<key>`` is the count of pixels at
    alpha 0.9 or more outside it, over the silhouette's pixels (what the splats show beyond the piece). ``cam``: the
    piece's camera."""
    o, lab = parts["o"], parts["labels"]
    total = float(parts["mass"].sum())
    masses = np.bincount(lab, weights=parts["mass"])
    rows = []
    fill_rows = np.arange(len(x))[o.fill_slice]
    for p in np.argsort(-masses):
        if masses[p] < BIG * total:
            break
        shown = parts["vis"] & (parts["crack_piece"] == p)
        tri = parts["tri_piece"] == p
        row = {"piece": int(p), "mass": float(masses[p]), "fill_n": int(shown.sum()), "tri_n": int(tri.sum())}
        rows.append(row)
        direction = parts["normals"][shown].mean(0) if shown.any() else (
            parts["tri_normals"][tri].mean(0) if tri.any() else None)
        if direction is None or np.linalg.norm(direction) < 1e-9:
            continue
        # the piece's material: its intact fill (its surface lies around it; its broken points are the crack band)
        sel = fill_rows[(lab[fill_rows] == p) & (d[fill_rows] < BROKEN)]
        pts = x[sel]
        lo, hi = pts.min(0), pts.max(0)
        cam = crack_camera(pts.mean(0), direction, lo, hi, size)
        row["cam"] = cam
        sil = silhouette(cam, pts, parts["h"])
        surf = subset(parts["surf"], parts["surf_piece"] == p)
        variants = [("without", surf)]
        if faces in ("fill", "both"):
            variants.append(("fill", type(surf).concat([surf, subset(parts["crack"], shown)])))
        if faces in ("triangles", "both"):
            variants.append(("tri", type(surf).concat([surf, subset(parts["tri"], tri)])))
        row["ms"] = {}
        for key, sp in variants:
            times = []
            for _ in range(5):
                t0 = time.perf_counter()
                _, alpha = render(sp, cam)
                times.append(time.perf_counter() - t0)
            row[key] = float(np.mean(alpha[sil] < ALPHA))
            if geometry is not None:
                geo = geometry.silhouette(cam, x, lab, p) if key == "without" else geo
                row[f"geo_{key}"] = float(np.mean(alpha[geo] < ALPHA))
                row[f"over_{key}"] = float(np.sum(alpha[~geo] >= ALPHA) / max(1, geo.sum()))
            row["ms"]["none" if key == "without" else key] = 1e3 * min(times)
        if rest is not None:
            row["floor"] = at_rest_share(rest, sel, direction, render, size)
    return rows


def whole_render_ms(parts, render, size=480):
    """Milliseconds (best of 5) to render the whole break from above and beside (the stills' first camera):
    ``none``; ``fill_all`` every fill face as ``gasp render`` draws a run (hidden ones at opacity 0); ``fill`` the
    shown ones only; ``tri`` the second candidate's."""
    from gasp_core.gs.camera import auto_camera
    surf = parts["surf"]
    cam = auto_camera(surf.means.min(0), surf.means.max(0), size, size, 30.0, azimuth_deg=-60.0, elevation_deg=35.0)
    sets = {"none": surf, "fill_all": type(surf).concat([surf, parts["crack"]]),
            "fill": type(surf).concat([surf, subset(parts["crack"], parts["vis"])]),
            "tri": type(surf).concat([surf, parts["tri"]])}
    out = {}
    for key, sp in sets.items():
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            render(sp, cam)
            times.append(time.perf_counter() - t0)
        out[key] = 1e3 * min(times)
    return out


def stills(parts, x, d, render, out_dir: Path, size=480, stem: str = "fracture_crack", faces: str = "fill"):
    """PNGs, each the whole break from above and beside, then the largest piece alone from its crack side:
    ``faces = "fill"`` two (without, with the first candidate's faces: ``<stem>_without.png``, ``<stem>_with.png``);
    ``"triangles"`` or ``"both"`` one with the second candidate's (``<stem>_triangles.png``; the first candidate's
    stills are left as they are)."""
    import imageio.v3 as iio
    from gasp_core.gs.camera import auto_camera
    surf, crack = parts["surf"], subset(parts["crack"], parts["vis"])
    lo, hi = surf.means.min(0), surf.means.max(0)
    whole = auto_camera(lo, hi, size, size, 30.0, azimuth_deg=-60.0, elevation_deg=35.0)
    big = int(np.bincount(parts["labels"], weights=parts["mass"]).argmax())
    shown = parts["vis"] & (parts["crack_piece"] == big)
    tri = parts["tri_piece"] == big
    fill = np.arange(len(x))[parts["o"].fill_slice]
    pts = x[fill[(parts["labels"][fill] == big) & (d[fill] < BROKEN)]]
    direction = parts["normals"][shown].mean(0) if shown.any() else parts["tri_normals"][tri].mean(0)
    piece_cam = crack_camera(pts.mean(0), direction, pts.min(0), pts.max(0), size)
    piece = subset(surf, parts["surf_piece"] == big)
    sets = {"without": (surf, piece),
            "with": (type(surf).concat([surf, crack]), type(surf).concat([piece, subset(parts["crack"], shown)])),
            "triangles": (type(surf).concat([surf, parts["tri"]]),
                          type(surf).concat([piece, subset(parts["tri"], tri)]))}
    paths = []
    for name in (("without", "with") if faces == "fill" else ("triangles",)):
        views = [(whole, sets[name][0]), (piece_cam, sets[name][1])]
        imgs = [render(sp, cam, background=np.ones(3))[0] for cam, sp in views]
        path = out_dir / f"{stem}_{name}.png"
        iio.imwrite(path, (np.clip(np.concatenate(imgs, 1), 0, 1) * 255).astype(np.uint8))
        paths.append(path)
    return paths


def _pct(v):
    return "-" if v is None else f"{100 * v:.1f} %"


def fill_table(rows) -> list[str]:
    """The first candidate's table, as ``benchmarks/results/crack_faces.md`` has always held it."""
    lines = ["| piece | mass (kg) | faces shown | alpha < 0.9 without faces | with faces | the same material unbroken "
             "(frame 0), same side |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['piece']} | {r['mass']:.3f} | {r['fill_n']} | {_pct(r.get('without'))} | "
                     f"{_pct(r.get('fill'))} | {_pct(r.get('floor'))} |")
    return lines


def compare_table(rows, faces: str) -> list[str]:
    """Both candidates (or the one asked for) side by side, with the render times."""
    cols = [("fill", "fill: faces shown", "fill: alpha < 0.9"),
            ("tri", "triangles: Gaussians", "triangles: alpha < 0.9")]
    cols = [c for c in cols if faces == "both" or c[0] == {"fill": "fill", "triangles": "tri"}[faces]]
    head = ["piece", "mass (kg)", "alpha < 0.9 without faces"]
    for _, n, a in cols:
        head += [n, a]
    head += ["unbroken (frame 0), same side", "render ms: none / " + " / ".join(k for k, _, _ in cols)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [str(r["piece"]), f"{r['mass']:.3f}", _pct(r.get("without"))]
        for k, _, _ in cols:
            cells += [str(r[f"{k}_n"]), _pct(r.get(k))]
        ms = r.get("ms", {})
        keys = ["none"] + [c[0] for c in cols]
        cells += [_pct(r.get("floor")), " / ".join(f"{ms[k]:.0f}" if k in ms else "-" for k in keys)]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--frames", type=int, default=None, help="default: 4 (donut), 8 (rod)")
    ap.add_argument("--scene", choices=("donut", "rod"), default="donut",
                    help="the donut shatter, or the T rod of tests/test_brittle.py broken under its own weight")
    ap.add_argument("--faces", choices=("fill", "triangles", "both"), default="fill",
                    help="which candidate's crack faces: the fill's (gasp_core.maps.crack_faces, what gasp simulate "
                         "writes; results in crack_faces[_rod].md), the split triangles' "
                         "(benchmarks/studies/crack_triangles.py), or both compared (crack_faces_compare[_rod].md)")
    args = ap.parse_args(argv)
    import tempfile
    from gasp_core.render.builtin import CpuRenderer
    render = CpuRenderer(jit=True)
    frames = args.frames or (8 if args.scene == "rod" else 4)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        scene = rod_scene(Path(tmp), args.engine) if args.scene == "rod" else ROOT / "examples" / "donut_shatter.toml"
        prep, x, d = run_to(args.engine, frames, scene)
        sim_s = time.perf_counter() - t0
        prep0, x0, d0 = run_to(args.engine, 0, scene)
    parts = scene_parts(prep, x, d)
    render(parts["surf"], crack_camera(np.zeros(3), np.ones(3), -np.ones(3), np.ones(3), 64))   # compile first
    rows = measure_pieces(parts, x, d, render, rest=(scene_parts(prep0, x0, d0), x0), faces=args.faces)
    stem = "fracture_crack" if args.scene == "donut" else "fracture_rod"
    paths = [] if args.faces != "fill" and parts["tri"].n == 0 else \
        stills(parts, x, d, render, ROOT / "docs", stem=stem, faces=args.faces)   # no split triangle: no new still
    n_faces, n_vis = len(parts["vis"]), int(parts["vis"].sum())
    what = "the shattered donut" if args.scene == "donut" else "the broken T rod"
    suffix = "" if args.scene == "donut" else "_rod"
    flag = "" if args.faces == "fill" else f" --faces {args.faces}"
    head = [f"# Crack faces on {what} ({args.engine}, frame {frames}; "
            f"`benchmarks/crack_faces.py --scene {args.scene}{flag}`)",
            "", f"{n_faces} fill points carry a crack face, {n_vis} shown at this frame "
            f"({len(np.unique(parts['labels']))} pieces; simulated in {sim_s:.0f} s)."]
    if args.faces == "fill":
        lines = head + [""] + fill_table(rows)
        out = ROOT / "benchmarks" / "results" / f"crack_faces{suffix}.md"
    else:
        whole = whole_render_ms(parts, render)
        lines = head + [f"The split triangles' faces: {parts['tri'].n} Gaussians from {parts['n_split']} split "
                        f"triangles (built in {1e3 * parts['tri_s']:.0f} ms).", ""] + compare_table(rows, args.faces)
        lines += ["", f"The whole break, {parts['surf'].n} surface Gaussians, 480 x 480 from above and beside, ms "
                  f"(best of 5): none {whole['none']:.0f}; fill, every face as a run draws them (hidden at opacity 0, "
                  f"+{n_faces}) {whole['fill_all']:.0f}; fill, the shown ones (+{n_vis}) {whole['fill']:.0f}; "
                  f"triangles (+{parts['tri'].n}) {whole['tri']:.0f}."]
        out = ROOT / "benchmarks" / "results" / f"crack_faces_compare{suffix}.md"
    lines += ["", "Stills: " + (", ".join(f"`docs/{q.name}`" for q in paths) or "none (nothing new to show)")]
    text = "\n".join(lines) + "\n"
    print(text)
    out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
