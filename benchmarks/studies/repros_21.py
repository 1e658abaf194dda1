"""Issue 21's repros through the real ``gasp`` command: exit status, stderr lines and wall time of each.

The scene is the issue's: a 600-Gaussian ball (radius 5 cm) on warp_mpm, n_grid 16, 1 frame, ground,
jelly E 2e4, nu 0.3, rho 300, with one value changed per repro. Each case runs in a fresh process;
the table (case, expected and measured exit status, number of stderr lines, seconds, the line)
goes to ``benchmarks/results/repros_21.md``.

    python benchmarks/studies/repros_21.py            # all cases (a few minutes; mujoco_flex ~10 s)
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "benchmarks" / "results" / "repros_21.md"

BASE = """frame_dt = 0.0333333
n_frames = 1
[engine]
name = "warp_mpm"
[domain]
n_grid = 16
[[boundary]]
kind = "ground"
height = 0.0
[[object]]
file = "ball.ply"
up_axis = "+z"
position = [0.0, 0.0, 0.1]
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
"""


def ball(path: Path, n: int = 600, radius: float = 0.05) -> None:
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    from gasp_core.testing.scenes_passive import fibonacci_sphere
    d = fibonacci_sphere(n)
    q = np.array([Rotation.align_vectors([v], [[1.0, 0.0, 0.0]])[0].as_quat() for v in d])
    write_gaussians(path, Gaussians(means=radius * d, scales=np.tile([1e-8, 0.006, 0.006], (n, 1)),
                                    rotations=q[:, [3, 0, 1, 2]], opacities=np.full(n, 3.0, np.float32),
                                    sh_dc=np.full((n, 3), 0.5, np.float32)))


def scene(d: Path, name: str, old: str = "", new: str = "", extra: str = "") -> str:
    text = BASE.replace(old, new, 1) if old else BASE
    (d / name).write_text(text + extra)
    return name


def gasp(d: Path, *argv: str) -> tuple[int, list[str], float]:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", *argv], cwd=d, capture_output=True, text=True,
                       timeout=600)
    return p.returncode, [ln for ln in p.stderr.splitlines() if ln.strip()], time.perf_counter() - t0


def sigterm_case(d: Path) -> tuple[int, list[str], float]:
    name = scene(d, "six.toml", "n_frames = 1", "n_frames = 6", "")
    (d / name).write_text((d / name).read_text().replace("frame_dt = 0.0333333", "frame_dt = 0.1"))
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "simulate", name, "-o", "stopped", "-q"],
                         cwd=d, stderr=subprocess.PIPE, text=True)
    while p.poll() is None and not list(d.glob(".stopped.partial-*/ball/frame_0002.ply")):
        time.sleep(0.01)
    p.send_signal(signal.SIGTERM)
    err = p.communicate()[1]
    return p.returncode, [ln for ln in err.splitlines() if ln.strip()], time.perf_counter() - t0


def cases(d: Path) -> list[tuple[str, int, tuple]]:
    os.mkfifo(d / "fifo.ply")
    flex2 = BASE.replace('name = "warp_mpm"', 'name = "mujoco_flex"')
    (d / "flex2.toml").write_text(flex2 + "\n" + flex2[flex2.index("[[object]]"):])
    return [
        ("scale = 1e-6", 2, ("simulate", scene(d, "a.toml", 'up_axis = "+z"', 'up_axis = "+z"\nscale = 1e-6'),
                             "-o", "o", "-q")),
        ("domain +-1e6, n_grid 16", 2, ("simulate", scene(d, "b.toml", "n_grid = 16",
                                        "n_grid = 16\nlo = [-1e6, -1e6, -1e6]\nhi = [1e6, 1e6, 1e6]"), "-o", "o", "-q")),
        ("rho = 1e300 (f32)", 2, ("simulate", scene(d, "c.toml", "rho = 300.0", "rho = 1e300"), "-o", "o", "-q")),
        ("n_grid 8", 2, ("simulate", scene(d, "e.toml", "n_grid = 16", "n_grid = 8"), "-o", "o", "-q")),
        ("-o /dev/full/x", 2, ("simulate", scene(d, "base.toml"), "-o", "/dev/full/x", "-q")),
        ("-o ball.ply/out", 2, ("simulate", "base.toml", "-o", "ball.ply/out", "-q")),
        ("FIFO object", 2, ("simulate", scene(d, "f.toml", 'file = "ball.ply"', 'file = "fifo.ply"'), "-o", "o", "-q")),
        ("/dev/zero object", 2, ("simulate", scene(d, "g.toml", 'file = "ball.ply"', 'file = "/dev/zero"'),
                                 "-o", "o", "-q")),
        ("/dev/zero scene", 2, ("simulate", "/dev/zero", "-o", "o", "-q")),
        ("n_frames = 1e9", 2, ("simulate", scene(d, "h.toml", "n_frames = 1", "n_frames = 1000000000"), "-o", "o",
                               "-q")),
        ("compare --engines warp_mpm,nope", 2, ("compare", "base.toml", "--engines", "warp_mpm,nope", "-o", "cmp")),
        ("two overlapping objects, mujoco_flex", 3, ("simulate", "flex2.toml", "-o", "o", "-q")),
    ]


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        ball(d / "ball.ply")
        for label, want, argv in cases(d):
            code, lines, s = gasp(d, *argv)
            rows.append((label, want, code, len(lines), s, lines[-1] if lines else ""))
            print(rows[-1][:5], flush=True)
        code, lines, s = sigterm_case(d)
        rows.append(("SIGTERM after frame 2 of 6", 130, code, len(lines), s, lines[-1] if lines else ""))
        code2, lines2, s2 = gasp(d, "simulate", "six.toml", "-o", "stopped", "-q", "--resume")
        rows.append(("--resume after it", 0, code2, len(lines2), s2, lines2[-1] if lines2 else ""))
    OUT.parent.mkdir(exist_ok=True)
    text = ["| case | expected exit | exit | stderr lines | s | last stderr line |", "|---|---|---|---|---|---|"]
    text += [f"| {a} | {b} | {c} | {n} | {s:.1f} | {ln.replace('|', '/')[:220]} |" for a, b, c, n, s, ln in rows]
    OUT.write_text("\n".join(text) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
