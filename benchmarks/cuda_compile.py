"""Every warp_mpm kernel compiled for CUDA on a machine without a GPU (issue 65's GPU path, checked between loans).

No GPU has been lent since round 58, and the kernels have grown since (rolling, cylinders, the trapezoid stress,
fracture). Warp compiles a module ahead of time for a CUDA architecture with its bundled NVRTC and no device
(``warp.compile_aot_module(module, arch=...)``, Warp's documentation "warp.compile_aot_module"). Every kernel of the
plugin is the result of a ``build_*(Ft)`` function (``gasp_warp_mpm.warmup.all_kernels``, the list the first run
compiles for the CPU; ``tests/test_warp_warmup.py`` checks no kernel is defined elsewhere), both schedules' included.
This script takes that list for float32 and float64 and compiles each kernel's module for ``--arch`` (default 90: H100
and H200), with the plugin's module options.

What it shows: each kernel is valid CUDA for the architecture (types, built-ins, atomics); not that it runs right
there (``benchmarks/gpu_checks.py`` on a lent device does that).

Writes ``cuda_compile.json`` and ``cuda_compile.md`` to ``--out`` (default ``benchmarks/results``): per module its
kernel, the seconds NVRTC took and the first line of any error; exits 1 if any module fails to compile.
Usage: ``python benchmarks/cuda_compile.py [--arch 90] [--precision f32 f64] [--out DIR]``.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def defined_kernels() -> set[str]:
    """The names of the ``@wp.kernel`` functions in gasp_warp_mpm's source."""
    import gasp_warp_mpm
    names = set()
    for f in Path(gasp_warp_mpm.__file__).parent.rglob("*.py"):
        names |= set(re.findall(r"@wp\.kernel[^\n]*\n\s*def (\w+)\(", f.read_text()))
    return names


def compile_modules(modules: list, arch: int) -> list[dict]:
    """Compile each Warp module for ``arch`` into a scratch folder; one row a module: ``module``, ``kernels``,
    ``seconds``, ``error`` ("" where it compiled)."""
    import warp as wp
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for m in modules:
            t0 = time.perf_counter()
            try:
                wp.compile_aot_module(m, arch=arch, module_dir=Path(d) / m.name)
                err = ""
            except Exception as exc:   # any failure of NVRTC or codegen is the finding: recorded, the rest go on
                text = str(exc).strip()
                err = f"{type(exc).__name__}: {text.splitlines()[0][:200] if text else ''}"
            rows.append({"module": m.name, "kernels": sorted(k.rpartition("__")[2] for k in m.kernels),
                         "seconds": round(time.perf_counter() - t0, 2), "error": err})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", type=int, default=90, help="CUDA architecture (90: H100, H200)")
    ap.add_argument("--precision", nargs="+", default=["f32", "f64"], choices=["f32", "f64"])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    a = ap.parse_args(argv)
    import warp as wp
    wp.config.quiet = True
    wp.init()
    from gasp_warp_mpm.warmup import all_kernels
    rows, t0 = [], time.perf_counter()
    for p in a.precision:
        kernels = all_kernels(wp.float32 if p == "f32" else wp.float64)
        modules = list({k.module.name: k.module for k in kernels}.values())
        rows += [{**r, "precision": p} for r in compile_modules(modules, a.arch)]
    wall = round(time.perf_counter() - t0, 1)
    bad = [r for r in rows if r["error"]]
    missed = sorted(defined_kernels() - {k for r in rows for k in r["kernels"]})
    a.out.mkdir(parents=True, exist_ok=True)
    rec = {"date": time.strftime("%Y-%m-%d"), "warp": wp.__version__, "arch": a.arch, "modules": len(rows),
           "kernels": sum(len(r["kernels"]) for r in rows), "failed": len(bad), "seconds": wall,
           "not_reached": missed, "rows": rows}
    (a.out / "cuda_compile.json").write_text(json.dumps(rec, indent=1) + "\n")
    lines = [f"# cuda_compile.py: warp_mpm's kernels compiled for sm_{a.arch} without a GPU", "",
             f"{rec['date']}, Warp {rec['warp']}, {', '.join(a.precision)}: {rec['modules']} modules, "
             f"{rec['kernels']} kernels, **{len(bad)} failed**, in {wall} s. Kernels of the source not in "
             f"`warmup.all_kernels` ({len(missed)}): {', '.join(missed) or 'none'}.", "",
             "| precision | module | kernels | s | error |", "|---|---|---|---:|---|"]
    lines += [f"| {r['precision']} | {r['module']} | {', '.join(r['kernels'])} | {r['seconds']} | {r['error']} |"
              for r in rows]
    (a.out / "cuda_compile.md").write_text("\n".join(lines) + "\n")
    print(f"{rec['modules']} modules, {rec['kernels']} kernels, {len(bad)} failed, {wall} s; "
          f"{len(missed)} kernels of the source not reached")
    for r in bad:
        print(f"FAILED {r['precision']} {r['module']}: {r['error']}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
