"""Where the frame's rebuild runs: in the frame loop, or on the writer thread beside the engine (issue 39).

``gasp simulate`` rebuilds each frame's Gaussians (``T^-1`` and the alpha rule, :class:`gasp_core.run.frames.Rebuilder`)
on its writer thread while the engine runs the next frame (:mod:`gasp_core.run.background`). This measures, on the
README donut's engine (taichi_mpm, the ``default`` level), the wall and CPU time of one frame in four modes, in
rounds that alternate the modes inside one process (so each mode sees the same machine load):

* ``loop``: the rebuild of the last frame, then the engine's frame (the pipeline before);
* ``writer 5 ms`` / ``writer 1 ms`` / ``writer 0.2 ms``: the rebuild on a second thread while the engine runs,
  Python's switch interval (``sys.setswitchinterval``) set to that value (:data:`gasp_core.run.background.SWITCH_INTERVAL`).

Writes ``benchmarks/results/bench_writer.md`` (and ``.json``). Usage::

    python benchmarks/bench_writer.py --rounds 6
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
MODES = {"loop": None, "writer 5 ms": 5e-3, "writer 1 ms": 1e-3, "writer 0.2 ms": 2e-4}


def measure(rounds: int, engine: str) -> dict:
    """Per mode, the wall and CPU seconds of each measured frame."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.run.frames import Rebuilder
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(load_scene(ROOT / "examples" / "donut_jelly.toml"))
    e = build_engine(engines()[engine], prep.setup)
    rebuild = Rebuilder(prep)
    e.step_frame()
    e.step_frame()   # kernels loaded, the first sort done
    out: dict = {m: [] for m in MODES}
    default = sys.getswitchinterval()
    for r in range(rounds):
        for mode, interval in MODES.items():
            x = np.asarray(e.positions(), dtype=np.float64)
            t0, c0 = time.perf_counter(), time.process_time()
            if interval is None:
                rebuild(r, x)
                e.step_frame()
            else:
                sys.setswitchinterval(interval)
                th = threading.Thread(target=rebuild, args=(r, x))
                th.start()
                e.step_frame()
                th.join()
                sys.setswitchinterval(default)
            out[mode].append((time.perf_counter() - t0, time.process_time() - c0))
    e.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--engine", default="taichi_mpm")
    a = ap.parse_args()
    load0 = os.getloadavg()
    res = measure(a.rounds, a.engine)
    load1 = os.getloadavg()
    base = float(np.median([w for w, _ in res["loop"]]))
    rows = ["# The frame's rebuild in the loop or on the writer (bench_writer.py)", "",
            f"{os.cpu_count()} CPU cores; load average at start {[round(v, 2) for v in load0]}, at end "
            f"{[round(v, 2) for v in load1]}; {a.rounds} rounds, the modes alternating in one process; "
            f"engine {a.engine}, the README donut at its default level.", "",
            "| mode | wall per frame (median) | / loop | CPU per frame (median) | cores | walls |",
            "|---|---:|---:|---:|---:|---|"]
    for mode, v in res.items():
        w = np.array(v)
        mw, mc = float(np.median(w[:, 0])), float(np.median(w[:, 1]))
        rows.append(f"| {mode} | {mw:.3f} s | {mw / base:.3f} | {mc:.3f} s | {mc / mw:.2f} | "
                    f"{', '.join(f'{t:.2f}' for t in w[:, 0])} |")
    text = "\n".join(rows) + "\n"
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "bench_writer.md").write_text(text)
    (RESULTS / "bench_writer.json").write_text(json.dumps({"load": [load0, load1], "frames": res}, indent=1))
    print(text)


if __name__ == "__main__":
    main()
