"""Issue 53's sand column against a jelly ball as a user makes it: Gaussians written to PLY files and run through
``gasp simulate`` (the reviewer's path), not points built by hand (``gasp_core.testing.sand_ball``, which the
conformance scene ``sand_on_ball`` uses).

The scene: a 6 x 6 x 15 cm column of flat Gaussians on the faces of a box (its base open, as a capture sees it),
``--spacing`` apart (the reviewer's column, 10 mm, and the issue's "surface Gaussians 5 mm apart"), sand (E 3.5e5 Pa,
nu 0.3, rho 1600, friction angle 30); beside it a 5 cm jelly ball (E 5e4 Pa, rho 1000) of 600 flat Gaussians on its
sphere, resting on the ground 5 mm beyond the column's +x face; ground friction 0.5; ``--n-grid`` cells over the default
domain (default :data:`N_GRID`, 50: the n_grid gasp's pile warning names at 32, where the column's pile is under
two cells high; a comma list runs each); ``--frames`` frames of 1/30 s. The free pile: the same column alone. Figures on the Gaussians' centres at
the last frame (the definitions of ``gasp_core.testing.sand_ball.pair_figures``, with the run's own ``dx``): sand on
the ball's side steeper than 50 degrees (share within 1 dx of it), the pile against the ball over the free pile's
height, the deepest sand Gaussian inside the ball's sphere about its Gaussians' centroid (dx; negative: a gap), the
ball's turn (Kabsch, degrees); and whether the run reached its last frame.
``normal_depth_dx`` (round 73, issue 67's must-show as worded): the deepest sand Gaussian below the ball's surface
along the ball's Gaussians' normals at the last frame, in dx (:func:`normal_depth`; positive: inside). ``--radius``
sets the ball's radius and ``--one-field`` runs the pair with ``contact_fields = false``. Lines since round 73 carry a
``date``.

    python benchmarks/sand_ball_pipeline.py --engines taichi_mpm,warp_mpm --spacing 0.01,0.005 --frames 60
    python benchmarks/sand_ball_pipeline.py --engines warp_mpm --n-grid 32,48,64   # against resolution
    python benchmarks/sand_ball_pipeline.py --engines warp_mpm --spacing 0.01 --n-grid 36,48 --radius 0.035

Writes ``benchmarks/results/sand_ball_pipeline.json`` (or ``--out``), a JSON line per run (its ``n_grid`` in it);
``--keep DIR`` keeps the runs there.
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SIDE_C, HEIGHT_C, R, GAP = 0.06, 0.15, 0.05, 0.005
N_BALL = 600
#: The n_grid gasp's pile warning names for this scene at n_grid 32 (gasp_core/prepare/runout.py: the column's pile,
#: 38 mm by Lube et al. 2004, is 1.9 cells of 19.6 mm there; 50 gives 3).
N_GRID = 50
SAND = {"name": "sand", "E": 3.5e5, "nu": 0.3, "rho": 1600.0, "friction_angle": 30.0}
BALL = {"name": "jelly", "E": 5e4, "nu": 0.3, "rho": 1000.0}


def _write(path: Path, means: np.ndarray, normals: np.ndarray, size: float, colour) -> Path:
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    q = np.array([Rotation.align_vectors([v], [[1.0, 0.0, 0.0]])[0].as_quat() for v in normals])
    n = len(means)
    g = Gaussians(means=means, scales=np.tile([1e-8, size, size], (n, 1)), rotations=q[:, [3, 0, 1, 2]],
                  opacities=np.full(n, 3.0, np.float32), sh_dc=np.tile(np.asarray(colour, np.float32), (n, 1)))
    return write_gaussians(path, g, overwrite=True)


def column_ply(path: Path, spacing: float) -> Path:
    """Flat Gaussians ``spacing`` apart on the column's four sides and top (base open), centred on x = SIDE_C / 2."""
    pts, nrm = [], []
    u = np.arange(spacing / 2, SIDE_C, spacing) - SIDE_C / 2
    w = np.arange(spacing / 2, HEIGHT_C, spacing)
    for axis in (0, 1):
        for sign in (-1.0, 1.0):
            a, b = np.meshgrid(u, w, indexing="ij")
            p = np.zeros((a.size, 3))
            p[:, axis] = sign * SIDE_C / 2
            p[:, 1 - axis] = a.ravel()
            p[:, 2] = b.ravel()
            n = np.zeros(3)
            n[axis] = sign
            pts.append(p)
            nrm.append(np.tile(n, (len(p), 1)))
    a, b = np.meshgrid(u, u, indexing="ij")
    pts.append(np.c_[a.ravel(), b.ravel(), np.full(a.size, HEIGHT_C)])
    nrm.append(np.tile([0.0, 0.0, 1.0], (a.size, 1)))
    return _write(path, np.concatenate(pts), np.concatenate(nrm), 0.6 * spacing, (0.8, 0.7, 0.4))


def ball_ply(path: Path, r: float = R) -> Path:
    """:data:`N_BALL` flat Gaussians (6 mm across, 6 / 5 cm of ``r``) on a sphere of radius ``r`` (m), each one's
    thin axis (its first, r1) along the sphere's outward normal."""
    from gasp_core.testing.scenes_passive import fibonacci_sphere
    d = fibonacci_sphere(N_BALL)
    return _write(path, r * d, d, 0.006 * r / R, (0.3, 0.5, 0.8))


def scene(work: Path, spacing: float, engine: str, frames: int, ball: bool, n_grid: int = N_GRID, r: float = R,
          options: dict | None = None) -> Path:
    """The scene's TOML under ``work``: the column, ``spacing`` (m), with (``ball``) the ball of radius ``r`` (m);
    ``options`` added to the engine's (e.g. ``{"contact_fields": False}``: one velocity field)."""
    import tomli_w
    d = work / f"spacing_{spacing:g}_r{r:g}"
    d.mkdir(exist_ok=True)
    col, bal = column_ply(d / "sand.ply", spacing), ball_ply(d / "ball.ply", r)   # the objects' names: their stems
    objs = [{"file": str(col), "up_axis": "+z", "recentre": False,
             "position": [SIDE_C / 2, 0.0, 0.0], "material": SAND}]
    if ball:
        objs.append({"file": str(bal), "up_axis": "+z", "recentre": False,
                     "position": [SIDE_C + GAP + r, 0.0, r], "material": {**BALL, "model": "elastic"}})
    opts = {"threads": 1} if engine == "taichi_mpm" else {}
    opts.update(options or {})
    doc = {"name": "sand_ball", "frame_dt": 1.0 / 30.0, "n_frames": frames,
           "engine": {"name": engine, "options": opts},
           "domain": {"n_grid": n_grid}, "boundary": [{"kind": "ground", "height": 0.0, "friction": 0.5}],
           "object": objs}
    tag = "".join(f"_{k}{v}" for k, v in sorted((options or {}).items()))
    path = work / f"{engine}_{spacing:g}_{n_grid}_r{r:g}_{int(ball)}{tag}.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def simulate(path: Path, out: Path) -> tuple[float, str | None]:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(path), "-o", str(out), "-q"],
                       capture_output=True, text=True)
    return time.perf_counter() - t0, None if p.returncode == 0 else (p.stderr.strip().splitlines() or ["?"])[-1]


def _means(run, name: str, frame: int) -> np.ndarray:
    """World-frame centres of object ``name``'s Gaussians at ``frame`` (m)."""
    from gasp_core.render.run import splats_from_gaussians
    k = [o["name"] for o in run.objects].index(name)
    pl = run.objects[k]["placement"]
    return splats_from_gaussians(run.read(frame, k), pl["R"], float(pl["scale"]), pl["t"]).means


def _world(run, name: str, frame: int):
    """(centres (n, 3) m, rotation matrices (n, 3, 3), scales (n, 3) m) of object ``name``'s Gaussians at
    ``frame``, world frame (the placement ``x = scale R x_file + t`` of ``run.json``)."""
    k = [o["name"] for o in run.objects].index(name)
    pl = run.objects[k]["placement"]
    g = run.read(frame, k)
    Rp, sc = np.asarray(pl["R"], np.float64), float(pl["scale"])
    return sc * g.means @ Rp.T + np.asarray(pl["t"], np.float64), np.einsum("ij,njk->nik", Rp, g.rotmats()), \
        sc * np.asarray(g.scales, np.float64)


def normal_depth(pair: Path) -> dict:
    """Issue 67's must-show on a finished pair run (folder ``pair``): at its last frame, the deepest sand Gaussian
    below the ball's surface along the ball's Gaussians' normals (each one's thin axis at that frame, outward), over
    the run's ``dx`` (``gasp_core.testing.sand_ball.normal_depth_dx``: sand within 2 dx of the surface; positive
    inside, negative a gap). Returns ``{"frames", "dx", "normal_depth_dx"}``."""
    from gasp_core.render.run import load_run
    from gasp_core.testing.sand_ball import gaussian_normals, normal_depth_dx
    run = load_run(pair)
    dx = float(json.loads((pair / "run.json").read_text())["domain"]["dx"])
    last = run.n_frames - 1
    xs = _world(run, "sand", last)[0]
    xb, rot, sc = _world(run, "ball", last)
    return {"frames": last, "dx": dx,
            "normal_depth_dx": normal_depth_dx(xs, xb, gaussian_normals(rot, sc, xb), dx)}


def figures(pair: Path, free: Path, r: float = R) -> dict:
    from gasp_core.render.run import load_run
    from gasp_studies.accuracy import kabsch, rotation_angle_deg
    run, alone = load_run(pair), load_run(free)
    rec = json.loads((pair / "run.json").read_text())
    dx = float(rec["domain"]["dx"])
    last, first = run.n_frames - 1, 0
    xs = _means(run, "sand", last)
    xb0, xb = _means(run, "ball", first), _means(run, "ball", last)
    free_xs = _means(alone, "sand", alone.n_frames - 1)
    c = xb.mean(0)
    rel = xs - c
    rr = np.linalg.norm(rel, axis=1)
    polar = np.degrees(np.arccos(np.clip(rel[:, 2] / np.maximum(rr, 1e-12), -1.0, 1.0)))
    steep = (rr <= r + dx) & (polar >= 50.0) & (polar <= 90.0)
    near = (rr <= r + 1.5 * dx) & (xs[:, 2] <= c[2] + r)
    h_pair = float(np.percentile(xs[near, 2], 95.0)) if near.any() else 0.0
    h_free = float(np.percentile(free_xs[:, 2], 99.0))
    Rm, _, _ = kabsch(xb0, xb)
    return {"frames": run.n_frames - 1, "dx": dx, "steep": float(steep.mean()), "h_pair_mm": 1e3 * h_pair,
            "h_free_mm": 1e3 * h_free, "pile": h_pair / h_free, "depth_dx": float(np.max(r - rr) / dx),
            "turn_deg": float(rotation_angle_deg(Rm)), "n_sand": int(len(xs)),
            "normal_depth_dx": normal_depth(pair)["normal_depth_dx"], "ball_r_m": r}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", type=lambda s: s.split(","), default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--spacing", type=lambda s: [float(v) for v in s.split(",")], default=[0.01, 0.005])
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--n-grid", type=lambda s: [int(v) for v in s.split(",")], default=[N_GRID],
                    help="grid cells along the domain's side, a comma list (one run each); default the n_grid the "
                         "pile warning names (N_GRID)")
    ap.add_argument("--radius", type=lambda s: [float(v) for v in s.split(",")], default=[R],
                    help="the ball's radius (m), a comma list (one run each); default R, 5 cm")
    ap.add_argument("--one-field", action="store_true",
                    help="the pair with contact_fields = false (one velocity field: the catch of the depth figure)")
    ap.add_argument("--keep", type=Path, default=None, help="write the runs here (kept) instead of a temporary folder")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "sand_ball_pipeline.json")
    args = ap.parse_args(argv)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        opts = {"contact_fields": False} if args.one_field else None
        for engine, spacing, n_grid, r in itertools.product(args.engines, args.spacing, args.n_grid, args.radius):
            runs = {}
            for ball in (True, False):
                o = opts if ball else None
                out = work / f"out_{engine}_{spacing:g}_{n_grid}_r{r:g}_{int(ball)}{'_1f' if o else ''}"
                runs[ball] = (out, *simulate(scene(work, spacing, engine, args.frames, ball, n_grid, r, o), out))
            rec = {"engine": engine, "spacing_m": spacing, "n_grid": n_grid, "frames_asked": args.frames,
                   "contact_fields": not args.one_field, "date": time.strftime("%Y-%m-%d"),
                   "seconds": round(runs[True][1], 1), "error": runs[True][2] or runs[False][2],
                   "load": os.getloadavg()[0]}
            if rec["error"] is None:
                rec.update(figures(runs[True][0], runs[False][0], r))
            print(json.dumps(rec), flush=True)
            with open(args.out, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
