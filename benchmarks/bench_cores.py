"""What a second core buys on this machine, whatever the code: the ceiling of issue 39's "1.7 cores".

Three workloads, each run alone and then as two processes at once (``--rounds`` times, alternating): a pure
Python loop (the interpreter: branches, little memory), SHA-256 of a 64 KB buffer (native integer work in the L1
cache) and a NumPy stream over two 200 MB float32 arrays (memory bandwidth). The throughput of two processes
over one is ``2 t_alone / t_pair`` (2.0: two independent cores; 1.0: the second process only takes turns). An MPM
substep moves every point's state and the grid through memory (P2G, G2P), so its parallel speed-up on this
machine is bounded by what the stream and the native rows show, not by Taichi or the code's split.

Run on a quiet machine (the figures are meaningless beside other work; the load average is recorded):
``python benchmarks/bench_cores.py --rounds 3``; writes ``benchmarks/results/bench_cores.md``.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

WORKLOADS = {
    "python loop": "x = 0\nfor i in range(30_000_000):\n    x += i * i % 7\n",
    "sha256 (native, L1)": ("import hashlib\nh = hashlib.sha256()\nbuf = b'x' * 65536\n"
                            "for _ in range(40000):\n    h.update(buf)\n"),
    "numpy stream (memory)": ("import numpy as np\na = np.ones(50_000_000, dtype=np.float32)\nb = np.empty_like(a)\n"
                              "for _ in range(30):\n    np.multiply(a, 1.0001, out=b)\n    a, b = b, a\n"),
}


def timed(code: str, n: int) -> list[float]:
    """Wall seconds of each of ``n`` processes running ``code`` at once (started together)."""
    procs = []
    for _ in range(n):
        procs.append(subprocess.Popen([sys.executable, "-c", "import time\nt=time.perf_counter()\n" + code
                                       + "print(time.perf_counter()-t)"], stdout=subprocess.PIPE, text=True))
    return [float(p.communicate()[0].strip()) for p in procs]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "bench_cores.md")
    a = ap.parse_args(argv)
    rows, load0 = [], os.getloadavg()[0]
    for name, code in WORKLOADS.items():
        alone, pair = [], []
        for _ in range(a.rounds):
            alone += timed(code, 1)
            pair.append(max(timed(code, 2)))
        alone.sort()
        pair.sort()
        t1, t2 = alone[len(alone) // 2], pair[len(pair) // 2]
        rows.append(f"| {name} | {t1:.2f} | {t2:.2f} | **{2.0 * t1 / t2:.2f}** | {min(alone):.2f}-{max(alone):.2f} / "
                    f"{min(pair):.2f}-{max(pair):.2f} |")
        print(rows[-1], flush=True)
    text = (f"`python benchmarks/bench_cores.py --rounds {a.rounds}` ({os.cpu_count()} CPUs; load average "
            f"{load0:.2f} before, {os.getloadavg()[0]:.2f} after; medians of {a.rounds} rounds)\n\n"
            "| workload | one process, s | two at once, s (the slower) | throughput of two / one | spread alone / two |\n"
            "|---|---:|---:|---:|---|\n" + "\n".join(rows) + "\n")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = a.out.with_name(a.out.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(a.out)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
