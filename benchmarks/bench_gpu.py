"""taichi_mpm on a GPU against the same machine's CPU cores, in one device call (issue 65).

Cases, each in a process of its own (Taichi has one runtime a process), under one deadline (``--budget`` s):

- ``donut_<device>``: the README donut (``examples/donut_jelly.toml``: 65,036 points, 69 substeps a frame, implicit
  viscosity, the contact's balance), ``--donut-frames`` frames; s a frame after frame 1 (which compiles), and the
  positions at frame 30 (1 s) saved, so CUDA's frames are measured against the CPU's (largest point distance, in dx);
- ``profile`` and ``block_jelly_1000000_cuda_profile``: three frames on CUDA under Taichi's kernel profiler;
- ``block_<material>_<n>``: a block at 8 points a cell (as ``bench_mpm.py``, n_grid grown to hold it), 10 substeps
  a frame, particle-substeps a second, for jelly from 65k to 16M points, sand and brittle at 1M;
- ``..._atomic``, ``..._tiles``: the same with the engine option ``p2g`` set (the GPU schedule's P2G: atomic, or tiled
  in shared memory, :mod:`gasp_taichi_mpm.schedule.tiles`; ``auto`` tiles from 262,144 points);
- ``donut_cuda_cpu``: the README donut on CUDA with the CPU schedule (``schedule = "cpu"``: today's design before
  issue 65), the baseline measured in the same call.

Writes ``bench_gpu.json`` and ``bench_gpu.md`` to ``--out`` (``$OUT`` on the device machine). Each case's line is
printed as it ends, so a case past the deadline leaves the others. Usage, on the device (``../shared/device``)::

    bash .device/setup.sh && PYTHONPATH=/tmp/site python3 benchmarks/bench_gpu.py --out $OUT
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DONUT = ROOT / "examples" / "donut_jelly.toml"
SUBSTEPS = 10


def donut_scene(device: str, folder: Path, schedule: str = "auto") -> Path:
    """The README donut with ``device`` and ``schedule`` in its engine options, written to ``folder``; schedule
    ``"tiles"`` or ``"atomic"``: the GPU schedule with that ``p2g`` (``"auto"`` chooses atomic at its 65k points);
    ``"det"``: the GPU schedule with ``deterministic = true`` (the fixed-point P2G)."""
    text = DONUT.read_text().replace('file = "data/', f'file = "{DONUT.parent}/data/')
    p2g = schedule if schedule in ("tiles", "atomic") else "auto"
    sched = schedule if schedule in ("cpu", "gpu") else "auto"
    text += f'\n[engine.options]\ndevice = "{device}"\nschedule = "{sched}"\np2g = "{p2g}"\n'
    if schedule == "det":
        text += "deterministic = true\n"
    path = folder / f"donut_{device}_{schedule}.toml"
    path.write_text(text)
    return path


def case_donut(device: str, frames: int, out: Path, schedule: str = "auto") -> dict:
    import hashlib
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import RunStats, run_engine
    with tempfile.TemporaryDirectory() as tmp:
        prep = prepare_scene(load_scene(donut_scene(device, Path(tmp), schedule)), "taichi_mpm")
    stats = RunStats()
    walls = []
    for rec in run_engine(prep.info, prep.setup, frames, stats):
        walls.append(rec.wall_s)
        last = rec.x
        if rec.frame == 30:
            np.save(out / f"donut_{device}_{schedule}_f30.npy", rec.x)
    after = walls[1:]
    n_sub = stats.engine.get("n_substeps", 0)
    return {"points": len(prep.setup.x), "n_substeps": n_sub, "frame1_s": walls[0],
            "s_per_frame_median": float(np.median(after)), "s_per_frame_min": float(np.min(after)),
            "s_per_frame_max": float(np.max(after)), "frames": len(walls), "dx": float(prep.setup.dx),
            "M_per_s": len(prep.setup.x) * n_sub / float(np.median(after)) / 1e6,
            "schedule": stats.engine.get("schedule"), "cg_iters": stats.engine.get("viscous_cg_iterations"),
            "p2g": stats.engine.get("p2g"), "sha1_last": hashlib.sha1(np.ascontiguousarray(last).tobytes()).hexdigest()}


def case_profile(frames: int) -> dict:
    """Per kernel, seconds a frame, from Taichi's kernel profiler over ``frames`` frames after frame 1."""
    import taichi as ti
    profiled(True)
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import RunStats, run_engine
    with tempfile.TemporaryDirectory() as tmp:
        prep = prepare_scene(load_scene(donut_scene("cuda", Path(tmp))), "taichi_mpm")
    kernels: dict = {}
    for rec in run_engine(prep.info, prep.setup, frames + 1, RunStats()):
        if rec.frame == 1:
            ti.sync()
            ti.profiler.clear_kernel_profiler_info()
        elif rec.frame == frames + 1:
            kernels["table"] = profile_table()
    return kernels


def block_setup(n_target: int, material: str, device: str, p2g: str = "auto", **options):
    """A block of about ``n_target`` points, 8 a cell, 1 cell over a ground, falling at 1 m/s; n_grid at least
    64 and twice the block's cells; ``p2g`` the engine option (``"auto"``: tiles on CUDA, or ``"atomic"``), and
    further engine ``options`` (``deterministic``, ``tile_sort_every``)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.mpm.substeps import mpm_stable_dt
    cells = max(1, int(round((n_target / 8) ** (1 / 3))))
    n_grid = max(64, 1 << int(np.ceil(np.log2(2 * cells))))
    dx = 1.0 / n_grid
    h = dx / 2
    side = cells * dx
    g = (np.arange(2 * cells) + 0.5) * h
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3).astype(np.float64)
    x += np.array([0.5 - side / 2, 0.5 - side / 2, 0.1 + dx])
    kw = {"tensile_strength": 2e3, "fracture_energy": 20.0} if material == "brittle" else {}
    mat = Material(material, E=1e5, nu=0.3, rho=1000.0, **kw)
    gravity = np.array([0.0, 0.0, -9.81])
    dt = mpm_stable_dt([mat], dx, gravity, height=1.0, v0_max=1.0)
    return SimSetup(x=x, v=np.array([0.0, 0.0, -1.0]), p_vol=h ** 3, body_id=0, materials=[mat], gravity=gravity,
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid,
                    boundaries=[Boundary("ground", height=0.1, friction=0.5)], frame_dt=SUBSTEPS * dt,
                    options={"device": device, "precision": "f32", "n_substeps": SUBSTEPS, "p2g": p2g, **options})


def profiled(on: bool) -> None:
    """Taichi's kernel profiler on for the engines built next (their ``ti.init``)."""
    if on:
        from gasp_taichi_mpm import engine as eng_mod
        init = eng_mod._quiet_init
        eng_mod._quiet_init = lambda t, **kw: init(t, kernel_profiler=True, **kw)


def profile_table(top: int = 30) -> str:
    """The kernel profiler's table, its ``top`` costliest kernels."""
    import contextlib
    import io
    import taichi as ti
    ti.sync()
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        ti.profiler.print_kernel_profiler_info("count")
    lines = buf.getvalue().strip().splitlines()
    return "\n".join(lines if len(lines) <= top + 7 else lines[:5 + top] + lines[-2:])


def case_block(n_target: int, material: str, device: str, frames: int, profile: bool = False,
               p2g: str = "auto", **options) -> dict:
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    profiled(profile)
    setup = block_setup(n_target, material, device, p2g, **options)
    t0 = time.perf_counter()
    eng = build_engine(get_engine("taichi_mpm"), setup)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    eng.step_frame()
    eng.positions()
    first = time.perf_counter() - t0
    if profile:
        import taichi as ti
        ti.sync()
        ti.profiler.clear_kernel_profiler_info()
    t0 = time.perf_counter()
    for _ in range(frames):
        eng.step_frame()
    x = eng.positions()
    wall = time.perf_counter() - t0
    st = eng.stats()
    table = profile_table() if profile else None
    eng.close()
    n = len(setup.x)
    if table:
        return {"points": n, "table": table}
    return {"points": n, "n_grid": setup.n_grid, "build_s": build, "frame1_s": first, "frames": frames,
            "s_per_frame": wall / frames, "M_per_s": n * SUBSTEPS * frames / wall / 1e6,
            "finite": bool(np.isfinite(x).all()), "schedule": st.get("schedule"), "p2g": st.get("p2g"),
            "sha1_last": __import__("hashlib").sha1(np.ascontiguousarray(x).tobytes()).hexdigest(), **options}


def run_case(name: str, args: list[str], timeout: float) -> dict:
    """``name`` in a subprocess of this script (``--case``), at most ``timeout`` s."""
    t0 = time.perf_counter()
    try:
        r = subprocess.run([sys.executable, __file__, "--case", name, *args], capture_output=True, text=True,
                           timeout=max(timeout, 1.0))
        line = [ln for ln in r.stdout.splitlines() if ln.startswith("{")]
        rec = json.loads(line[-1]) if r.returncode == 0 and line else \
            {"error": f"exit {r.returncode}: " + " | ".join(r.stderr.strip().splitlines()[-4:])}
    except subprocess.TimeoutExpired:
        rec = {"error": f"past its {timeout:.0f} s"}
    rec.update(case=name, wall_s=round(time.perf_counter() - t0, 1))
    print(json.dumps(rec), flush=True)
    return rec


def markdown(doc: dict) -> str:
    lines = [f"# bench_gpu.py: taichi_mpm, {doc['gpu']}, {doc['date']}", "",
             f"Host: {doc['cpu_count']} CPU threads. Each case in its own process; frame 1 compiles.", "",
             "| case | points | s a frame (median) | M particle-substeps/s | frame 1 s | note |",
             "|---|---:|---:|---:|---:|---|"]
    for r in doc["cases"]:
        if "table" in r:
            continue
        if "error" in r:
            lines.append(f"| {r['case']} | | | | | {r['error'][:120]} |")
            continue
        spf = r.get("s_per_frame_median", r.get("s_per_frame"))
        note = f"n_grid {r['n_grid']}" if "n_grid" in r else f"{r.get('n_substeps')} substeps, CG {r.get('cg_iters')}"
        lines.append(f"| {r['case']} | {r['points']} | {spf:.4f} | {r['M_per_s']:.1f} | {r['frame1_s']:.1f} | "
                     f"{note}; schedule {r.get('schedule')}, p2g {r.get('p2g')} |")
    for k, v in doc.get("derived", {}).items():
        lines.append(f"\n{k}: {v}")
    for r in doc["cases"]:
        if "table" in r:
            what = "README donut" if r["case"] == "profile" else r["case"]
            lines += ["", f"Kernel profiler ({what}, 3 frames):", "", "```", r["table"].strip(), "```"]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--budget", type=float, default=460.0, help="seconds for all the cases")
    ap.add_argument("--donut-frames", type=int, default=31)
    ap.add_argument("--sizes", default="65000,1000000,4000000,16000000")
    ap.add_argument("--only", default=None, help="comma-separated case names (default all)")
    ap.add_argument("--case", default=None, help=argparse.SUPPRESS)
    ap.add_argument("rest", nargs="*", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.case:   # inside a case's process
        if a.case.startswith("donut_"):
            _, device, schedule, *_run = a.case.split("_")   # a last "_runK": the same case again
            rec = case_donut(device, a.donut_frames, a.out, schedule)
        elif a.case == "profile":
            rec = case_profile(3)
        else:
            _, material, n, device, *suffix = a.case.split("_")
            opts = {"deterministic": True} if "det" in suffix else {}
            opts.update({"tile_sort_every": int(x[4:]) for x in suffix if x.startswith("sort")})
            rec = case_block(int(n), material, device, 3, profile="profile" in suffix,
                             p2g=next((x for x in ("atomic", "tiles") if x in suffix), "auto"), **opts)
        print(json.dumps(rec))
        return 0
    try:
        gpu = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True).stdout.strip() or "no GPU"
    except OSError:
        gpu = "no GPU"
    cases = [("block_jelly_16000000_cuda", []), ("block_jelly_16000000_cuda_atomic", []),
             ("block_jelly_1000000_cuda", []), ("block_jelly_1000000_cuda_atomic", []),
             ("donut_cuda_auto", []), ("donut_cpu_auto", []), ("donut_cuda_tiles", [])]
    cases += [(f"block_jelly_{n}_cuda", []) for n in a.sizes.split(",") if n not in ("1000000", "16000000")]
    cases += [("block_jelly_65000_cuda_tiles", []), ("block_sand_1000000_cuda", []),
              ("block_brittle_1000000_cuda", []), ("block_jelly_1000000_cuda_profile", []), ("profile", []),
              ("donut_cuda_cpu", ["--donut-frames", "4"])]
    cases += [("donut_cuda_det", []), ("donut_cuda_det_run2", []), ("block_jelly_1000000_cuda_det", []),
              ("block_jelly_1000000_cuda_det_run2", []), ("block_jelly_16000000_cuda_det", []),
              ("block_jelly_16000000_cuda_sort4", []), ("block_jelly_4000000_cuda_sort4", [])]
    cases += [(f"block_{m}_1000000_cuda_det{r}", []) for m in ("sand", "brittle") for r in ("", "_run2")]
    if a.only:   # in the order given
        extra = dict(cases)
        cases = [(c, extra.get(c, [])) for c in a.only.split(",")]
    end = time.perf_counter() + a.budget
    doc = {"gpu": gpu, "date": datetime.date.today().isoformat(), "cpu_count": os.cpu_count(),
           "python": platform.python_version(), "cases": []}
    for name, extra in cases:
        left = end - time.perf_counter()
        if left < 20:
            doc["cases"].append({"case": name, "error": "not run: the budget was spent"})
            continue
        doc["cases"].append(run_case(name, [*extra, "--out", str(a.out)], left))
        (a.out / "bench_gpu.json").write_text(json.dumps(doc, indent=1))   # each case kept, should a later one hang
    by = {r["case"]: r for r in doc["cases"]}
    derived = {}
    c, p = by.get("donut_cuda_auto", {}), by.get("donut_cpu_auto", {})
    if "s_per_frame_median" in c and "s_per_frame_median" in p:
        derived["README donut, CUDA against this machine's CPU cores"] = \
            f"{p['s_per_frame_median'] / c['s_per_frame_median']:.1f}x faster"
        fa, fb = a.out / "donut_cuda_auto_f30.npy", a.out / "donut_cpu_auto_f30.npy"
        if fa.exists() and fb.exists():
            d = np.linalg.norm(np.load(fa) - np.load(fb), axis=1)
            derived["README donut after 1 s, CUDA against CPU: largest point distance"] = \
                f"{d.max() / c['dx']:.2g} dx (median {np.median(d) / c['dx']:.2g} dx)"
        fc = a.out / "donut_cuda_tiles_f30.npy"
        if fa.exists() and fc.exists():
            d = np.linalg.norm(np.load(fa) - np.load(fc), axis=1)
            derived["README donut after 1 s, CUDA tiled against CUDA atomic P2G: largest point distance"] = \
                f"{d.max() / c['dx']:.2g} dx (median {np.median(d) / c['dx']:.2g} dx)"
    for n, t, at in (("65000", "block_jelly_65000_cuda_tiles", "block_jelly_65000_cuda"),
                     ("1000000", "block_jelly_1000000_cuda", "block_jelly_1000000_cuda_atomic"),
                     ("16000000", "block_jelly_16000000_cuda", "block_jelly_16000000_cuda_atomic")):
        t, at = by.get(t, {}), by.get(at, {})
        if "M_per_s" in t and "M_per_s" in at:
            derived[f"jelly block {n} points, tiled P2G against atomic P2G"] = f"{t['M_per_s'] / at['M_per_s']:.2f}x"
    for det, run2, base in (("donut_cuda_det", "donut_cuda_det_run2", "donut_cuda_auto"),
                            ("block_jelly_1000000_cuda_det", "block_jelly_1000000_cuda_det_run2",
                             "block_jelly_1000000_cuda_atomic"),
                            ("block_jelly_16000000_cuda_det", None, "block_jelly_16000000_cuda_atomic")):
        d, b = by.get(det, {}), by.get(base, {})
        key = "s_per_frame_median" if "s_per_frame_median" in d else "s_per_frame"
        if key in d and key in b:
            derived[f"{det}: its cost against {base} (float atomics)"] = f"{d[key] / b[key]:.2f}x the time"
    for name, d in by.items():   # every case run twice ("_run2"): the same bits?
        r2 = by.get(name + "_run2", {})
        if "sha1_last" in d and "sha1_last" in r2:
            derived[f"{name}: two runs' last positions"] = \
                "the same bits" if d["sha1_last"] == r2["sha1_last"] else "DIFFERENT bits"
    for n in ("16000000", "4000000"):
        t, t4 = by.get(f"block_jelly_{n}_cuda", {}), by.get(f"block_jelly_{n}_cuda_sort4", {})
        if "M_per_s" in t and "M_per_s" in t4:
            derived[f"jelly block {n} points, tiles sorted every 4 substeps against every substep"] = \
                f"{t4['M_per_s'] / t['M_per_s']:.2f}x"
    doc["derived"] = derived
    (a.out / "bench_gpu.json").write_text(json.dumps(doc, indent=1))
    (a.out / "bench_gpu.md").write_text(markdown(doc))
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
