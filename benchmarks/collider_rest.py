"""Issue 38 item 2's must-show through `gasp simulate`: the ball of 600 flat Gaussians with its fill (jelly E 2e4 Pa,
nu 0.3, rho 300, R 5 cm; ``benchmarks/contact_mustshow.py``) dropped 5 cm onto a box mesh collider (0.4 x 0.4 x
0.1 m, friction 0.5, its top at ``TOP``), 40 frames, n_grid 16 on a 0.6 m domain (dx 37.5 mm); the same ball dropped
5 cm onto a ground at the collider top's height, as the reference. Per engine and contact: the largest horizontal
travel of the Gaussians' centroid (mm), its height over the last 10 frames against the ground run's (in dx: positive
floats above where it rests on the ground), and the lowest 1 % of Gaussians' gap to the surface (dx).

Run: ``python benchmarks/collider_rest.py [--engines warp_mpm taichi_mpm] [--tag after]``; the table goes to stdout
and ``benchmarks/results/collider_rest.md`` (a tagged run appends its table under the tag). Wall seconds are of the
whole `gasp simulate`, with the machine's load average beside them.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import contact_mustshow as cm

TOP = 0.1            # m: the box collider's top face, and the reference ground's height
LO, HI, N_GRID = (-0.3, -0.3, -0.1), (0.3, 0.3, 0.5), 16
DX = (HI[0] - LO[0]) / N_GRID


def box_mesh(path: Path) -> Path:
    import trimesh
    trimesh.creation.box(extents=(0.4, 0.4, TOP)).apply_translation((0.0, 0.0, TOP / 2)).export(path)
    return path


def scene(ply: Path, engine: str, contact: str, box: Path | None) -> str:
    ground = 0.0 if box else TOP
    text = f"""
frame_dt = 0.0333333
n_frames = 40
[engine]
name = "{engine}"
options = {{ contact = "{contact}" }}
[domain]
lo = {list(LO)}
hi = {list(HI)}
n_grid = {N_GRID}
[[boundary]]
kind = "ground"
height = {ground}
friction = 0.5
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, {TOP + cm.RADIUS + cm.DROP}]
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
"""
    if box:
        text += f'[[collider]]\nmesh = "{box}"\nfriction = 0.5\n'
    return text


def run(tmp: Path, engine: str, contact: str, on_box: bool) -> dict:
    from gasp_core.gs.io import read_gaussians
    ply = cm.ball(tmp / "ball.ply", 0.0)
    box = box_mesh(tmp / "box.obj") if on_box else None
    toml = tmp / f"{engine}_{contact}_{on_box}.toml"
    toml.write_text(scene(ply, engine, contact, box))
    out = tmp / f"out_{toml.stem}"
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(toml), "-o", str(out), "-q",
                        "--overwrite"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    frames = sorted((out / ply.stem).glob("frame_*.ply"))
    if not frames:
        return {"error": r.stderr.strip()[-300:]}
    means = [read_gaussians(f).means for f in frames]
    c = np.array([m.mean(axis=0) for m in means])
    # written in the object's frame: its lowest Gaussian at frame 0 is where `position` put the bottom
    low = np.array([np.sort(m[:, 2])[:max(1, len(m) // 100)].mean() for m in means]) \
        - means[0][:, 2].min() + TOP + cm.RADIUS + cm.DROP
    travel = np.linalg.norm(c[:, :2] - c[0, :2], axis=1)
    out = {"travel_mm": 1e3 * float(travel.max()), "z_rest": float(c[-10:, 2].mean()), "frames": len(frames),
           "gap_dx": float((low[-10:].mean() - TOP) / DX), "wall_s": wall, "load": load}
    if r.returncode:
        out["error"] = r.stderr.strip().splitlines()[-1][:160]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--contacts", nargs="+", default=["auto"])
    ap.add_argument("--tag", default="")
    a = ap.parse_args()
    rows = ["| engine | contact | travel on the box (mm) | rest height on the box - on the ground (dx) | lowest 1 % "
            "of Gaussians above the box / the ground (dx) | frames | wall s (box / ground) | load avg |",
            "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as d:
        for engine in a.engines:
            for contact in a.contacts:
                box, ground = (run(Path(d), engine, contact, on_box) for on_box in (True, False))
                err = "; ".join(f["error"] for f in (box, ground) if "error" in f)
                if "z_rest" not in box or "z_rest" not in ground:
                    rows.append(f"| {engine} | {contact} | error: {err} | | | | | |")
                else:
                    rows.append(f"| {engine} | {contact} | {box['travel_mm']:.2f} | "
                                f"{(box['z_rest'] - ground['z_rest']) / DX:+.3f} | {box['gap_dx']:+.3f} / "
                                f"{ground['gap_dx']:+.3f} | {box['frames']}{' (' + err + ')' if err else ''} | "
                                f"{box['wall_s']:.0f} / {ground['wall_s']:.0f} | {box['load']:.1f} / "
                                f"{ground['load']:.1f} |")
                print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).parent / "results" / "collider_rest.md"
    res.parent.mkdir(exist_ok=True)
    head = (f"`python benchmarks/collider_rest.py` (the 600-Gaussian ball dropped 5 cm onto a box mesh collider, "
            f"40 frames, n_grid {N_GRID}, dx {DX * 1e3:.1f} mm; heights against the same drop onto a ground at the "
            f"box top's height)\n")
    old = res.read_text() if a.tag and res.exists() else head
    res.write_text(old + (f"\n### {a.tag}\n" if a.tag else "\n") + "\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
