"""Issue 53 item 5: two jelly balls stacked, their gap with one velocity field and with one field per body.

The scene is the conformance scene ``stacked_gap`` (``gasp_core.testing.scenes_pairs``: two 5 cm balls, E 1e5 Pa,
rho 1000, lattice points at dx / 2, n_grid 24 on 0.6 m, the top one let go 1.5 dx over the bottom one, in a square
tube of frictionless walls 0.25 dx clear of their sides). Variants: ``open`` (no tube, the balls in a 0.6 m box off
the grid's symmetry: the scene before), ``light`` (the jelly of ``jittered_ball_rest``, E 2e4 Pa, rho 300),
``gaussians`` (``N_SURFACE`` = 602 points on each ball's sphere, each a 1 mm sheet of its share of the surface: the
issue's surface Gaussians, 7.2 mm apart), ``n_grid`` 32, and the three together (the issue's balls: dx 18.75 mm,
the Gaussians 7.2 mm apart), and ``set_down`` (the top ball let go touching, no drop) alone and with the issue's
balls; each with the two fields (the default) and with one field
(``contact_fields = false``, the rule before).

Figures per run: the lattices' gap (the conformance check's: nearest points less half of each one's spacing; dx)
averaged over the last 0.5 s, its range there, the deepest overlap over the whole run (the impact), the top ball's
centroid off the bottom one's horizontally at the end (dx), and the seconds per frame (frames 4 on, after the
build). With ``gaussians``, also the gap on the Gaussians: the nearest distance from a top-ball Gaussian to the
tangent plane of its nearest bottom-ball Gaussian (signed, mm and dx), and the nearest distance between Gaussian
centres (the issue's figure; two such spheres set exactly touching read ``touch_ref``).

    python benchmarks/bench_stacked.py --engines warp_mpm,taichi_mpm

Writes ``benchmarks/results/stacked.json`` (or ``--out``), one JSON line per run. ``--timing 60`` appends the seconds
per frame of the scene with a field per body and with one field, alternated ``--reps`` times, and their ratio.

``--sha FRAMES`` instead prints the sha1 of the positions after FRAMES frames of the scenes the contact must leave
bit for bit (the sand column beside the jelly ball on two fields; the column alone; one jelly ball alone; the
stacked balls with ``contact_fields = false``), per engine: run it on two checkouts and compare, e.g.
``PYTHONPATH=BASE:BASE/plugins/taichi_mpm:BASE/plugins/warp_mpm python benchmarks/bench_stacked.py --sha 10``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
N_SURFACE = 602
SHEET = 1e-3


def _local(name: str):
    """This checkout's module ``gasp_core/testing/<name>.py``, also when PYTHONPATH points at another checkout."""
    spec = importlib.util.spec_from_file_location(name, HERE.parent / "gasp_core" / "testing" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    th = math.pi * (1.0 + 5.0 ** 0.5) * i
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], axis=1)


def stack_setup(S, info, *, open_: bool = False, light: bool = False, gaussians: bool = False, n_grid: int = 0,
                set_down: bool = False, options: dict | None = None):
    """The ``stacked_gap`` setup with the variants of the module's docstring (``S``: the scenes_pairs module)."""
    from gasp_core.seam.setup import Material
    if set_down:
        S.STACK_DROP = 0.0
    if n_grid:
        S.N_GRID, S.DX = n_grid, S.SIDE / n_grid
        S.STACK_GROUND = 4 * S.DX
    if light:
        S.STACK_MAT = Material("jelly", E=2e4, nu=0.3, rho=300.0)
    s = S._build_stack(info)
    if open_:
        half = s.domain_hi[0] / 2
        s.x = np.asarray(s.x) + [S.SIDE / 2 + 0.3 * S.DX - half, S.SIDE / 2 + 0.2 * S.DX - half, 0.0]
        s.domain_hi = np.full(3, S.SIDE)
        s.boundaries = [b for b in s.boundaries if b.kind == "ground"]
    import dataclasses
    body = np.asarray(s.body_id)
    if gaussians:
        x = np.asarray(s.x)
        surf = [x[body == b].mean(axis=0) + S.STACK_R * fibonacci_sphere(N_SURFACE) for b in (0, 1)]
        vol_s = 4 * math.pi * S.STACK_R ** 2 / N_SURFACE * SHEET
        s = dataclasses.replace(s, x=np.concatenate([*surf, x]), v=0.0,
                                p_vol=np.r_[np.full(2 * N_SURFACE, vol_s), s.p_vol],
                                body_id=np.r_[np.repeat([0, 1], N_SURFACE), body], n_render=2 * N_SURFACE)
    return dataclasses.replace(s, options={"threads": 1, **(options or {})})


def gaussian_gaps(x: np.ndarray, body: np.ndarray, n: int) -> tuple[float, float]:
    """``(plane_gap, centre_gap)``, m, on the first ``n`` rows (the Gaussians): the least signed distance from a top
    ball's Gaussian to the tangent plane of its nearest bottom-ball Gaussian (normal from the bottom ball's centroid),
    and the least distance between Gaussian centres of the two."""
    from scipy.spatial import cKDTree
    g, gb = x[:n], body[:n]
    a, b = g[gb == 0], g[gb == 1]
    c0 = x[body == 0].mean(axis=0)
    d, k = cKDTree(a).query(b)
    nrm = a[k] - c0
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return float(np.min(np.einsum("ij,ij->i", b - a[k], nrm))), float(d.min())


def run(engine: str, frames: int, **kw) -> dict:
    from gasp_core.seam import EngineDivergence
    from gasp_core.seam.plugins import get_engine
    from gasp_core.seam.runner import RunStats, run_engine
    S = _local("scenes_pairs")
    info = get_engine(engine)
    s = stack_setup(S, info, **kw)
    body = np.asarray(s.body_id)
    name = {k: v for k, v in kw.items() if k != "options"}
    xs, stamps = [s.x.copy()], [time.perf_counter()]
    try:
        for rec in run_engine(info, s, frames, RunStats()):
            xs.append(rec.x)
            stamps.append(time.perf_counter())
    except EngineDivergence as e:
        return {"engine": engine, **name, "diverged": str(e)}
    xs, t = np.stack(xs), np.arange(len(xs)) * s.frame_dt
    lat = np.ones(len(body), bool)
    lat[:s.n_render] = not kw.get("gaussians")
    vol = np.asarray(s.p_vol)
    gaps = np.array([S.surface_gap(x[lat], body[lat], vol[lat]) for x in xs]) / S.DX
    last = t >= t[-1] - S.STACK_AVG_T - 1e-9
    c0, c1 = xs[-1][body == 0].mean(axis=0), xs[-1][body == 1].mean(axis=0)
    out = {"engine": engine, **name, "fields": (kw.get("options") or {}).get("contact_fields", True),
           "gap_dx": float(gaps[last].mean()), "gap_range_dx": [float(gaps[last].min()), float(gaps[last].max())],
           "deepest_dx": float(gaps.min()), "deepest_t": float(t[int(np.argmin(gaps))]),
           "off_axis_dx": float(np.linalg.norm((c1 - c0)[:2]) / S.DX),
           "s_per_frame": float((stamps[-1] - stamps[4]) / (len(stamps) - 5)), "frames": frames}
    if kw.get("gaussians"):
        gg = np.array([gaussian_gaps(x, body, s.n_render) for x in xs[last]])
        out["gaussian_gap_mm"] = float(1e3 * gg[:, 0].mean())
        out["gaussian_gap_dx"] = float(gg[:, 0].mean() / S.DX)
        out["gaussian_centre_gap_mm"] = float(1e3 * gg[:, 1].mean())
        ref = fibonacci_sphere(N_SURFACE) * S.STACK_R
        both = np.concatenate([ref, ref + [0, 0, 2 * S.STACK_R]])
        out["touch_ref_centre_mm"] = 1e3 * gaussian_gaps(both, np.repeat([0, 1], N_SURFACE), 2 * N_SURFACE)[1]
    return out


def sha(engines: list[str], frames: int) -> None:
    """Print ``engine scene sha1`` for the scenes of ``--sha``."""
    import hashlib
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    B = _local("sand_ball")
    S = _local("scenes_pairs")
    for engine in engines:
        info = get_engine(engine)
        import dataclasses
        two = stack_setup(S, info)
        keep = np.asarray(two.body_id) == 0
        one = dataclasses.replace(two, x=two.x[keep], v=0.0, p_vol=two.p_vol[keep], body_id=0,
                                  materials=two.materials[:1], n_render=0)
        scenes = {"sand_ball_two_fields": B.pair_setup(options={"threads": 1}),
                  "sand_alone": B.pair_setup(ball=False, options={"threads": 1}),
                  "one_ball": one,
                  "stacked_one_field": stack_setup(S, info, options={"contact_fields": False})}
        for name, s in scenes.items():
            tr = run_trace(info, s, frames)
            print(engine, name, hashlib.sha1(np.ascontiguousarray(tr.x[-1]).tobytes()).hexdigest(), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--out", default=str(HERE / "results" / "stacked.json"))
    ap.add_argument("--sha", type=int, default=0, metavar="FRAMES")
    ap.add_argument("--timing", type=int, default=0, metavar="FRAMES",
                    help="instead: seconds per frame (frames 4 on) of the scene with a field per body and with one, "
                         "alternated --reps times; appended to --out")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--variants", default="", help="indices into the variants, e.g. 0,5 (default: all)")
    a = ap.parse_args()
    if a.sha:
        return sha(a.engines.split(","), a.sha)
    if a.timing:
        for engine in a.engines.split(","):
            t = {True: [], False: []}
            for _ in range(a.reps):
                for fields in (True, False):
                    t[fields].append(run(engine, a.timing, options={"contact_fields": fields})["s_per_frame"])
            r = {"engine": engine, "timing_frames": a.timing, "fields_s_per_frame": t[True], "one_s_per_frame": t[False],
                 "ratio_of_least": min(t[True]) / min(t[False])}
            print(json.dumps(r), flush=True)
            with open(a.out, "a") as f:
                f.write(json.dumps(r) + "\n")
        return None
    variants = [{}, {"open_": True}, {"light": True}, {"gaussians": True}, {"n_grid": 32},
                {"light": True, "gaussians": True, "n_grid": 32},
                {"set_down": True}, {"set_down": True, "light": True, "gaussians": True, "n_grid": 32}]
    if a.variants:
        variants = [variants[int(i)] for i in a.variants.split(",")]
    with open(a.out, "a" if a.variants else "w") as f:
        for engine in a.engines.split(","):
            for v in variants:
                for fields in (True, False):
                    r = run(engine, a.frames, **v, options={"contact_fields": fields})
                    print(json.dumps(r), flush=True)
                    f.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
