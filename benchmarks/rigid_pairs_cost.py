"""Round 63 (issues 66 / 67): where the time of rigid bodies among three or more goes (``gasp_core.mpm.rigid_pairs``,
``docs/rigid.md`` "Round 63: the cost of rigid pairs"), on a heap of many rigid blocks
(``gasp_core.testing.scenes_rigid3.heap_setup``: ``cols x cols`` columns of ``layers`` blocks on a ground, the top
ones dropped half a cell).

Per run: the build's seconds, the frames' seconds (after a first frame that compiles), the host's recolouring per
frame (``colouring.recolour``, timed apart), and with ``--profile`` the time per kernel: warp_mpm each recorded
launch timed alone with a device synchronise (on the CPU the kernels run in turn, so the sum is the substeps' time),
taichi_mpm Taichi's kernel profiler. The physics' figures (each block's centre at the end, their hash, and the
largest move of a centre over the last half of the run) say whether two builds give the same run.

    python benchmarks/rigid_pairs_cost.py --engine warp_mpm [--n-grid 48] [--frames 12] [--cols 4] [--layers 3]
        [--off] [--profile] [--tag NAME] [--device cuda] [--side 0.02]

``--off``: ``colouring.RIGID_PAIRS`` False (the rule before round 62: one field for all). Results:
``benchmarks/results/rigid_pairs_cost_<engine>_<n_grid>_<tag>.json`` and ``.md``.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def warp_timed(eng, table: dict) -> None:
    """Replace ``eng._substep`` (``eng`` an engine, or the engine's class) by one that times each recorded launch
    alone (seconds summed into ``table`` by kernel name; a synchronise after each)."""
    import warp as wp

    def substep(self, s: int, capturing: bool = False) -> None:
        eng = self
        for cmd in list(eng._pre) + list(eng._launches) + [eng._passive_at[s], eng._tick]:
            for one in ([] if cmd is None else [cmd.first, cmd.then] if hasattr(cmd, "first") else [cmd]):
                t0 = time.perf_counter()
                one.launch()
                wp.synchronize_device(eng.device)
                table[one.kernel.key] += time.perf_counter() - t0
        if eng.visc is not None:
            raise SystemExit("viscous scenes are not timed here")
    if isinstance(eng, type):
        eng._substep = substep
    else:
        eng._substep = substep.__get__(eng)


def timed_recolour() -> list:
    """``colouring.recolour`` timed: the seconds it took are summed into the list's one entry."""
    from gasp_core.mpm import colouring
    host = [0.0]
    real = colouring.recolour

    def recolour(e):
        t = time.perf_counter()
        try:
            return real(e)
        finally:
            host[0] += time.perf_counter() - t
    colouring.recolour = recolour
    return host


def run_cup(speed: float, frames: int, off: bool, profile: bool) -> dict:
    """The cup of ``benchmarks/cup_drop.py`` on warp_mpm (n_grid 96) at ``speed`` (m/s) for ``frames`` frames: its
    wall time, recolouring and, with ``profile``, its kernels (every frame's, the break's before included)."""
    import tempfile
    from gasp_core.mpm import colouring
    from gasp_warp_mpm.engine import WarpMPMEngine
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import cup_drop
    colouring.RIGID_PAIRS = not off
    table: dict = defaultdict(float)
    if profile:
        warp_timed(WarpMPMEngine, table)
    host = timed_recolour()
    with tempfile.TemporaryDirectory() as tmp:
        res = cup_drop.run("warp_mpm", speed, frames, Path(tmp) / "cup")
    xs = res["xs"]
    st = res["stats"]
    return {"engine": "warp_mpm", "case": f"cup {speed} m/s", "n_grid": 96, "frames": frames,
            "rigid_pairs": not off, "wall_s": res["wall_s"], "recolour_s": host[0],
            "break": json.loads(json.dumps(st.fragments[0] if st.fragments else {}, default=str)),
            "kernels_s": dict(sorted(table.items(), key=lambda kv: -kv[1])),
            "lowest_mm": 1e3 * min(float(x[:, 2].min()) for x in xs),
            "x_hash": hashlib.sha256(np.round(np.asarray(xs[-1], float), 9).tobytes()).hexdigest()[:8]}


def run(engine: str, n_grid: int, frames: int, cols: int, layers: int, off: bool, profile: bool,
        device: str = "cpu", side: float = 0.04) -> dict:
    """The figures of one run (module notes); ``device`` the engine option (``"cuda"`` on a lent GPU), ``side`` the
    blocks' width (m; 0.02 at n_grid 96 fits 10 x 10 columns in the 0.48 m domain)."""
    from gasp_core.mpm import colouring
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.scenes_rigid3 import heap_setup
    colouring.RIGID_PAIRS = not off
    if profile and engine == "taichi_mpm":
        from gasp_taichi_mpm import engine as eng_mod
        init = eng_mod._quiet_init
        eng_mod._quiet_init = lambda t, **kw: init(t, kernel_profiler=True, **kw)
    s = heap_setup(n_grid, cols, layers, side=side)
    s.options = {**(s.options or {}), "device": device}
    t0 = time.perf_counter()
    eng = build_engine(get_engine(engine), s)
    build = time.perf_counter() - t0
    host = timed_recolour()
    t0 = time.perf_counter()
    eng.step_frame()
    eng.positions()
    first = time.perf_counter() - t0
    table: dict = defaultdict(float)
    if profile and engine == "warp_mpm":
        warp_timed(eng, table)
    if profile and engine == "taichi_mpm":
        import taichi as ti
        ti.sync()
        ti.profiler.clear_kernel_profiler_info()
    host[0] = 0.0
    body, pm = np.asarray(s.body_id), np.asarray(s.p_mass, float)
    nb = len(s.materials)

    def centres():
        x = eng.positions().astype(float)
        return np.array([(x[body == k] * pm[body == k, None]).sum(0) / pm[body == k].sum() for k in range(nb)])
    C = []
    t0 = time.perf_counter()
    for _ in range(frames):
        eng.step_frame()
        C.append(centres())
    wall = time.perf_counter() - t0
    if profile and engine == "taichi_mpm":
        import taichi as ti
        ti.sync()
        from taichi.profiler.kernel_profiler import get_default_kernel_profiler
        prof = get_default_kernel_profiler()
        prof._update_records()   # noqa: SLF001 (Taichi's own table, read rather than printed)
        prof._count_statistics()   # noqa: SLF001
        for name, rec in prof._statistical_results.items():   # noqa: SLF001
            table[re.sub(r"_c\d+_\d+_kernel_\d+_\w+$", "", name)] += rec.total_time / 1e3   # per kernel, its tasks summed
    stats = eng.stats()
    eng.close()
    C = np.array(C)
    half = C[len(C) // 2:]
    return {"engine": engine, "device": device, "n_grid": n_grid, "frames": frames, "bodies": nb,
            "points": int(len(s.x)),
            "rigid_pairs": not off, "substeps": int(stats.get("n_substeps", 0) or getattr(s, "n_substeps", 0) or 0),
            "build_s": build, "first_frame_s": first, "wall_s": wall, "per_frame_s": wall / frames,
            "recolour_s": host[0], "kernels_s": dict(sorted(table.items(), key=lambda kv: -kv[1])),
            "creep_mm": float(1e3 * np.abs(half - half[0]).max()) if len(half) else 0.0,
            "centres_hash": hashlib.sha256(np.round(C[-1], 12).tobytes()).hexdigest()[:8],
            "lowest_centre_mm": float(1e3 * C[-1, :, 2].min())}


def markdown(r: dict) -> str:
    """The run's figures as a markdown table."""
    lines = [f"# rigid_pairs_cost: {r['engine']}, n_grid {r['n_grid']}, {r['bodies']} bodies, {r['points']} points, "
             f"rigid pairs {'on' if r['rigid_pairs'] else 'off'}", "",
             f"build {r['build_s']:.2f} s, first frame {r['first_frame_s']:.2f} s, {r['frames']} frames "
             f"{r['wall_s']:.2f} s ({r['per_frame_s']:.3f} s a frame; substeps {r['substeps']}), recolouring "
             f"{r['recolour_s']:.3f} s, creep {r['creep_mm']:.4f} mm, centres {r['centres_hash']}", ""]
    if r["kernels_s"]:
        total = sum(r["kernels_s"].values())
        lines += ["| kernel | s | share |", "|---|---|---|"]
        lines += [f"| {k} | {v:.3f} | {100 * v / total:.1f} % |" for k, v in r["kernels_s"].items()]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, default=48)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--cols", type=int, default=4)
    ap.add_argument("--layers", type=int, default=3)
    ap.add_argument("--off", action="store_true")
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--tag", default="")
    ap.add_argument("--device", default="cpu", help="the engine option device (cuda on a lent GPU)")
    ap.add_argument("--side", type=float, default=0.04, help="the blocks' width, m")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--json", type=Path, default=None, help="also append the run's figures as one JSON line here")
    ap.add_argument("--cup", type=float, default=None, help="the cup at this speed (m/s) instead of the heap")
    a = ap.parse_args()
    if a.cup is not None:
        r = run_cup(a.cup, a.frames, a.off, a.profile)
        print(json.dumps(r, indent=1))
        if not a.no_write:
            stem = ROOT / "benchmarks" / "results" / f"rigid_pairs_cost_cup_{a.cup:g}_{a.tag or 'run'}"
            stem.with_suffix(".json").write_text(json.dumps(r, indent=1))
        return
    r = run(a.engine, a.n_grid, a.frames, a.cols, a.layers, a.off, a.profile, a.device, a.side)
    md = markdown(r)
    print(md)
    if a.json is not None:
        with open(a.json, "a") as f:
            f.write(json.dumps({"tag": a.tag, **r}) + "\n")
    if not a.no_write:
        stem = ROOT / "benchmarks" / "results" / f"rigid_pairs_cost_{a.engine}_{a.n_grid}_{a.tag or 'run'}"
        stem.with_suffix(".json").write_text(json.dumps(r, indent=1))
        stem.with_suffix(".md").write_text(md)


if __name__ == "__main__":
    main()
