"""The studio's quick level (issue 32, item 3): how long after ``gasp simulate --json`` is launched the first
simulated frame of the donut is there, with cold and warm kernel caches, per engine and quality setting.

The scene is the one ``gasp studio`` writes for ``examples/data/donut_v3dg.ply``: the whole object, ``up_axis
= "+z"``, ``jelly`` (E 2e4 Pa, nu 0.3, rho 300 kg/m^3, viscosity 4 Pa s, as ``examples/donut_jelly.toml``),
a ground at 0, dropped from 5 cm, ``frame_dt`` 1/30, ``n_grid`` 64. Each run is a subprocess
``python -m gasp_core.cli.main simulate SCENE -o OUT --json --quality LEVEL --frames N``, as the studio launches
it; its stdout events are read as they come, stamped with the wall time since the launch and the child's CPU
time (user + system from ``/proc/PID/stat``, all its threads) at that moment, and the frame files are looked
for on disk (in the run's partial folder) every 50 ms.

A "cold" run gets a fresh, empty kernel cache (``TI_OFFLINE_CACHE_FILE_PATH`` for Taichi, ``WARP_CACHE_PATH``
for Warp: https://nvidia.github.io/warp/api_reference/_generated/warp.config.kernel_cache_dir.html); the "warm"
run after it uses the cache the cold one filled. Where the time goes, from the run's ``run.json``: ``start``
(Python's start, imports, the scene checks and ``prepare_s``: reading, placement, fill), ``build_s`` (the
engine's construction, Warp's module compiles included), frame 1's ``sim_s`` (Taichi compiles its kernels at
their first call, Warp the ones not loaded at build), and the steady frames' ``sim_s``.

Usage::

    python benchmarks/bench_studio_level.py --frames 6 --engines taichi_mpm --settings draft,default,draft_g32 \
        --tag taichi_mpm
    git archive HEAD | (mkdir -p /tmp/gasp-base && tar -x -C /tmp/gasp-base)      # a change against its base:
    python benchmarks/bench_studio_level.py --frames 6 --engines warp_mpm --base /tmp/gasp-base --tag warp_mpm
    python benchmarks/bench_studio_level.py --frames 2 --engines warp_mpm --settings draft --caches cold \
        --rounds 3 --base /tmp/gasp-base --tag warp_mpm_rounds

With ``--base`` each run of this checkout is followed by the same run of the base (its own fresh cache when
cold), the frame files of the two are compared byte for byte (``same_frames``), and the markdown ends with
the medians of this / base. Writes ``benchmarks/results/bench_studio_level[_TAG].{json,md}``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import queue
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"
TICK = os.sysconf("SC_CLK_TCK")
PLUGINS = ("taichi_mpm", "warp_mpm", "mujoco_flex", "newton", "genesis", "blender", "render_gsplat")

#: name -> (quality level, extra scene keys: domain, object, engine options)
CANDIDATES = {
    "draft": ("draft", {}),
    "default": ("default", {}),
    "draft_g48": ("draft", {"domain": {"n_grid": 48}}),
    "draft_g32": ("draft", {"domain": {"n_grid": 32}}),
    "draft_cfl08": ("draft", {"options": {"cfl": 0.8}}),
}


def studio_scene(engine: str, extra: dict) -> str:
    """The studio's donut scene as TOML, with ``extra``'s domain keys and engine options."""
    dom = {"n_grid": 64, "padding": 0.5, **extra.get("domain", {})}
    opts = extra.get("options", {})
    lines = ['name = "donut_studio"', "frame_dt = 0.0333333333", "n_frames = 36", "gravity = [0.0, 0.0, -9.81]", "",
             "[engine]", f'name = "{engine}"']
    if opts:
        lines.append("options = { " + ", ".join(f"{k} = {v!r}" for k, v in opts.items()) + " }")
    lines += ["", "[domain]"] + [f"{k} = {v!r}" for k, v in dom.items()]
    lines += ["", "[[boundary]]", 'kind = "ground"', "height = 0.0", "friction = 0.5", "",
              "[[object]]", f'file = "{DONUT.as_posix()}"', 'up_axis = "+z"', "position = [0.0, 0.0, 0.05]",
              "[object.material]", 'name = "jelly"', "E = 2.0e4", "nu = 0.3", "rho = 300.0", "viscosity = 4.0"]
    return "\n".join(lines) + "\n"


def _cpu_s(pid: int) -> float | None:
    """User + system CPU seconds of process ``pid`` so far (all its threads), or None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICK


def _reader(stream, q: queue.Queue, pid: int, t0: float) -> None:
    for line in stream:
        q.put((time.perf_counter() - t0, _cpu_s(pid), line))
    q.put(None)


def _frame_file(out: Path, frame: int) -> bool:
    name = f"frame_{frame:04d}.ply"
    return any(out.parent.glob(f".{out.name}.partial-*/*/{name}")) or any(out.glob(f"*/{name}"))


def run_once(src: Path, scene: Path, out: Path, level: str, frames: int, cache: Path) -> dict:
    """One ``gasp simulate --json`` subprocess of checkout ``src``: its events' times, the frame files' times, CPU
    and ``run.json``."""
    env = {**os.environ, "TI_OFFLINE_CACHE_FILE_PATH": str(cache / "ti"), "WARP_CACHE_PATH": str(cache / "wp"),
           "PYTHONPATH": os.pathsep.join([str(src)] + [str(src / "plugins" / p) for p in PLUGINS])}
    cmd = [sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "--json",
           "--quality", level, "--frames", str(frames)]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
    q: queue.Queue = queue.Queue()
    threading.Thread(target=_reader, args=(p.stdout, q, p.pid, t0), daemon=True).start()
    events, files = [], {}
    while True:
        try:
            item = q.get(timeout=0.05)
        except queue.Empty:
            item = ()
        if item is None:
            break
        if item:
            t, cpu, line = item
            try:
                events.append({"t": round(t, 2), "cpu": cpu, **json.loads(line)})
            except ValueError:
                pass
        for f in range(1, 4):
            if f not in files and _frame_file(out, f):
                files[f] = round(time.perf_counter() - t0, 2)
    rc = p.wait()
    return {"exit": rc, "wall_s": round(time.perf_counter() - t0, 2), "events": events, "files": files,
            **_record(out)}


def _record(out: Path) -> dict:
    run = out / "run.json"
    if not run.exists():
        return {}
    d = json.loads(run.read_text())
    sims = [f.get("sim_s") for f in d["frames"]]
    return {"prepare_s": round(d["prepare_s"], 2), "build_s": round(d["build_s"], 2), "sim_s": sims,
            "n_points": d["n_points"], "n_substeps": d["engine_stats"].get("n_substeps"),
            "n_grid": d["engine_stats"].get("n_grid"), "n_passive": d["engine_stats"].get("n_passive", 0)}


def same_frames(a: Path, b: Path) -> bool | None:
    """Whether the runs in ``a`` and ``b`` wrote the same frame files, byte for byte (None: one is missing)."""
    fa, fb = sorted(a.glob("*/frame_*.ply")), sorted(b.glob("*/frame_*.ply"))
    if not fa or [f.relative_to(a) for f in fa] != [f.relative_to(b) for f in fb]:
        return None
    return all(x.read_bytes() == y.read_bytes() for x, y in zip(fa, fb))


def summarise(rec: dict) -> dict:
    """The figures of one run: times to the start, frame 1 and frame 3 (event, file), CPU, the breakdown."""
    ev = {e["frame"]: e for e in rec["events"] if e.get("event") == "frame"}
    start = next((e for e in rec["events"] if e.get("event") == "start"), {})
    sims = [s for s in rec.get("sim_s", [])[2:] if s is not None]
    walls = [ev[f]["t"] - ev[f - 1]["t"] for f in sorted(ev) if f >= 2 and f - 1 in ev]
    f1 = ev.get(1, {})
    out = {"start_s": start.get("t"), "frame1_s": f1.get("t"), "frame1_file_s": rec["files"].get(1),
           "frame1_cpu_s": f1.get("cpu"), "frame3_s": ev.get(3, {}).get("t"), "frame3_file_s": rec["files"].get(3),
           "per_frame_wall_s": round(statistics.median(walls), 2) if walls else None,
           "per_frame_sim_s": round(statistics.median(sims), 2) if sims else None}
    if start.get("t") is not None and "prepare_s" in rec:
        out["import_s"] = round(start["t"] - rec["prepare_s"], 2)
    if sims and len(rec.get("sim_s", [])) > 1 and rec["sim_s"][1] is not None:
        out["frame1_extra_s"] = round(rec["sim_s"][1] - statistics.median(sims), 2)   # compile at first call
    return out


COLUMNS = ("checkout", "round", "engine", "setting", "cache", "load", "start_s", "import_s", "prepare_s", "build_s",
           "frame1_extra_s", "frame1_s", "frame1_file_s", "frame1_cpu_s", "frame3_s", "per_frame_wall_s",
           "per_frame_sim_s", "n_substeps", "n_points", "same_frames", "exit")


def _markdown(doc: dict) -> str:
    lines = ["# The studio's quick level: time to the first frame of the donut (bench_studio_level.py)", "",
             f"Machine: {doc['cpu_count']} cores, {doc['platform']}; load average at start {doc['load_start']}, "
             f"at end {doc['load_end']} (the machine is shared: wall times are loaded ones where the load exceeds "
             f"{doc['cpu_count']}; `frame1_cpu_s` is the run's own CPU time). {doc['frames']} frames per run. "
             "Seconds from the launch of `gasp simulate --json` (the studio's subprocess): `start_s` the start "
             "event (imports, scene checks, prepare), `frame1_s` / `frame3_s` the frame events, `frame1_file_s` "
             "frame 1's file on disk; `import_s` = start - prepare_s; `frame1_extra_s` = frame 1's sim_s - the "
             "steady frames' (kernel compiles at first call); per frame: median of frames 2.., wall and sim.", "",
             *([doc["note"], ""] if doc.get("note") else []),
             "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in doc["rows"]:
        lines.append("| " + " | ".join("" if r.get(c) is None else str(r.get(c)) for c in COLUMNS) + " |")
    pairs: dict = {}
    for t, b in zip(doc["rows"], doc["rows"][1:]):
        if (t["checkout"], b["checkout"]) == ("this", "base") and t.get("frame1_s") and b.get("frame1_s"):
            pairs.setdefault((t["engine"], t["setting"], t["cache"]), []).append(
                (t["frame1_s"] / b["frame1_s"], t["frame1_cpu_s"] / b["frame1_cpu_s"],
                 (t["frame1_s"] - t["start_s"]) / (b["frame1_s"] - b["start_s"])))
    if pairs:
        lines += ["", "This checkout against the base, run after run (median over rounds): time to frame 1, wall "
                  "and CPU, and from the start event to frame 1 (the engine's build and frame 1: the compiles), wall, "
                  "this / base.", "", "| engine | setting | cache | rounds | wall | CPU | start to frame 1, wall |",
                  "|---|---|---|---:|---:|---:|---:|"]
        for (e, st, c), v in pairs.items():
            lines.append(f"| {e} | {st} | {c} | {len(v)} | {statistics.median(x[0] for x in v):.2f} | "
                         f"{statistics.median(x[1] for x in v):.2f} | {statistics.median(x[2] for x in v):.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    ap.add_argument("--settings", default=",".join(CANDIDATES))
    ap.add_argument("--caches", default="cold,warm", help="cold (a fresh cache), warm (the cold run's), or both")
    ap.add_argument("--base", type=Path, default=None,
                    help="also run a base checkout (before the change), alternating with this one")
    ap.add_argument("--rounds", type=int, default=1, help="repeat each run (cold: a fresh cache each round)")
    ap.add_argument("--tag", default="")
    a = ap.parse_args(argv)
    srcs = {"this": ROOT, **({"base": a.base.resolve()} if a.base else {})}
    doc = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "frames": a.frames,
           "load_start": [round(x, 2) for x in os.getloadavg()], "rows": []}
    with tempfile.TemporaryDirectory(prefix="gasp-studio-bench-") as tmp:
        tmp = Path(tmp)
        for name in a.settings.split(","):
            level, extra = CANDIDATES[name]
            for engine in a.engines.split(","):
                scene = tmp / f"{engine}_{name}.toml"
                scene.write_text(studio_scene(engine, extra))
                for r, kind, (label, src) in ((r, k, x) for r in range(a.rounds) for k in a.caches.split(",")
                                              for x in srcs.items()):
                    cache, load = tmp / f"cache_{label}_{engine}_{name}_{r}", round(os.getloadavg()[0], 2)
                    out = tmp / f"out_{label}_{engine}_{name}_{kind}_{r}"
                    rec = run_once(src, scene, out, level, a.frames, cache)
                    row = {"checkout": label, "round": r, "engine": engine, "setting": name, "cache": kind,
                           "load": load, **summarise(rec),
                           **{k: v for k, v in rec.items() if k not in ("events", "files")}}
                    if label == "base":   # the change leaves the frames as they were
                        row["same_frames"] = doc["rows"][-1]["same_frames"] = same_frames(
                            out, tmp / f"out_this_{engine}_{name}_{kind}_{r}")
                    doc["rows"].append(row)
                    print(json.dumps({c: row.get(c) for c in COLUMNS}), file=sys.stderr, flush=True)
    doc["load_end"] = [round(x, 2) for x in os.getloadavg()]
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = "bench_studio_level" + (f"_{a.tag}" if a.tag else "")
    (RESULTS / f"{stem}.json").write_text(json.dumps(doc, indent=2) + "\n")
    (RESULTS / f"{stem}.md").write_text(_markdown(doc))
    print(_markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
