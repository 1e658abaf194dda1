"""Issue 53/54's kitchen must-show: no spinach Gaussian outside the pan's wall at the last frame, with the pan (the
unselected rest of the capture) as the collider, against the ground plane alone (``rest_collider = false``).

**The pan's wall, from the capture** (:func:`pan_wall`; the pan is no clean ring in this capture, so no circle is
fitted): around the pile's centre (the median of the spinach Gaussians' centres at frame 0, horizontal), in each of
:data:`SECTORS` azimuth sectors, the wall lies at the :data:`NEAREST`-th nearest opaque (opacity >= 0.1) rest
Gaussian centre beyond the pile's own start in that sector (the farthest spinach centre there at frame 0), among
those above the pan's bottom (the ground under the selection, + :data:`LIFT`) and below the pile's top
(+ :data:`TOP`). A spinach Gaussian is **outside the wall** when its centre's horizontal distance from the pile's
centre exceeds its sector's wall radius; by construction none is at frame 0. Sectors with fewer than
:data:`NEAREST` rest Gaussians have no wall (open).

Run: ``python benchmarks/kitchen_wall.py [--out DIR]``: simulates ``examples/kitchen_spinach.toml`` as it stands
and with ``rest_collider = false`` (30 frames each, taichi_mpm), prints the table and writes
``benchmarks/results/kitchen_wall.md``. The figures count Gaussians beyond the wall by more than 0, 1/2, 1 and 2
grid cells (``dx``), and the largest distance beyond it.
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
from scipy.special import expit

ROOT = Path(__file__).resolve().parents[1]
KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
#: Azimuth sectors around the pile's centre.
SECTORS = 36
#: The wall in a sector is this nearest rest Gaussian beyond the pile's start (one or two are floaters).
NEAREST = 3
#: The band of rest Gaussians that make the wall: above the pan's bottom by LIFT, below the pile's top + TOP (m).
LIFT, TOP = 0.01, 0.05
#: Distances beyond the wall counted, in grid cells.
CELLS = (0.0, 0.5, 1.0, 2.0)


def _sector(xy: np.ndarray) -> np.ndarray:
    return np.floor((np.arctan2(xy[:, 1], xy[:, 0]) + np.pi) / (2 * np.pi) * SECTORS).astype(int) % SECTORS


def pan_wall(rest: np.ndarray, start: np.ndarray, ground: float) -> tuple[np.ndarray, np.ndarray]:
    """The pan's wall (module notes): the pile's centre (2,) and each sector's wall radius (SECTORS,), metres
    (inf: no wall). ``rest`` (n, 3) the opaque rest Gaussians' centres, ``start`` (m, 3) the spinach Gaussians'
    centres at frame 0, ``ground`` the pan's bottom, world metres (z up)."""
    c0 = np.median(start[:, :2], axis=0)
    band = (rest[:, 2] >= ground + LIFT) & (rest[:, 2] <= start[:, 2].max() + TOP)
    q = rest[band, :2] - c0
    a_q, r_q = _sector(q), np.hypot(q[:, 0], q[:, 1])
    s = start[:, :2] - c0
    a_s, r_s = _sector(s), np.hypot(s[:, 0], s[:, 1])
    wall = np.full(SECTORS, np.inf)
    for i in range(SECTORS):
        r0 = r_s[a_s == i].max() if (a_s == i).any() else 0.0
        beyond = np.sort(r_q[(a_q == i) & (r_q > r0)])
        if len(beyond) >= NEAREST:
            wall[i] = beyond[NEAREST - 1]
    return c0, wall


def beyond_wall(x: np.ndarray, centre: np.ndarray, wall: np.ndarray) -> np.ndarray:
    """Each Gaussian centre's ``x`` (m, 3) horizontal distance beyond its sector's wall, metres (negative: inside)."""
    s = x[:, :2] - centre
    return np.hypot(s[:, 0], s[:, 1]) - wall[_sector(s)]


def _wall_run(run_dir) -> dict:
    """A kitchen run folder read against the pan's wall: ``mask`` (the spinach rows), ``dx``, ``centre``, ``wall``
    (:func:`pan_wall`), ``first`` and ``last`` (the Gaussians of frames 0 and the last)."""
    import json
    from gasp_core.render.run import load_run, moving_mask
    run = load_run(run_dir)
    rec = json.loads((Path(run_dir) / "run.json").read_text())
    ground = min(b["height"] for b in rec["boundaries"] if b["kind"] == "ground")
    mask = moving_mask(run)
    first, last = run.splats(0), run.splats(run.n_frames - 1)
    rest = first.means[~mask][expit(first.opacities[~mask].astype(np.float64)) >= 0.1]
    centre, wall = pan_wall(rest, first.means[mask], ground)
    return {"mask": mask, "dx": float(rec["domain"]["dx"]), "centre": centre, "wall": wall, "first": first,
            "last": last}


def measure(run_dir) -> dict:
    """The figures of a kitchen run folder: ``n`` spinach Gaussians, ``beyond`` (dict cells -> count beyond the
    wall by more than that many ``dx``), ``max_m`` the largest distance beyond it (m), ``dx``, ``at_start`` (count
    outside at frame 0, 0 by construction)."""
    w = _wall_run(run_dir)
    mask, dx, centre, wall = w["mask"], w["dx"], w["centre"], w["wall"]
    d = beyond_wall(w["last"].means[mask], centre, wall)
    return {"n": int(mask.sum()), "dx": dx, "max_m": float(d.max()), "wall_m": wall.tolist(),
            "beyond": {c: int((d > c * dx).sum()) for c in CELLS},
            "at_start": int((beyond_wall(w["first"].means[mask], centre, wall) > 0).sum())}


def who_left(run_dir, k: int = 10) -> list[dict]:
    """Each spinach Gaussian beyond the wall at the last frame, beside its neighbours in the input model: its colour
    (SH band 0 as RGB in [0, 1]), its motion over the model's time (the largest distance of its centre from where it
    is at ``dynamic_time``, over 21 times in [0, 1], file units) and the same figures' means over its ``k`` nearest
    unselected and ``k`` nearest selected Gaussians at ``dynamic_time`` (file frame). A Gaussian of the pan caught by
    the select box looks like its unselected neighbours (dark, still); a leaf like the selection."""
    import tomllib
    from gasp_core.gs.splatv import read_splatv, splatv_at
    w = _wall_run(run_dir)
    mask = w["mask"]
    d = beyond_wall(w["last"].means[mask], w["centre"], w["wall"])
    obj = tomllib.loads(KITCHEN.read_text())["object"][0]
    base, motion = read_splatv(KITCHEN.parent / obj["file"])
    at = splatv_at(base, motion, obj["dynamic_time"])
    track = np.stack([splatv_at(base, motion, t).means for t in np.linspace(0.0, 1.0, 21)])
    moves = np.linalg.norm(track - at.means, axis=2).max(axis=0)
    rgb = np.clip(0.5 + 0.28209479177387814 * at.sh_dc.reshape(len(moves), -1)[:, :3].astype(np.float64), 0.0, 1.0)
    rows = np.flatnonzero(mask)
    out = []
    for i in np.flatnonzero(d > 0):
        r = rows[i]
        dist = np.linalg.norm(at.means - at.means[r], axis=1)
        dist[r] = np.inf
        near = {name: np.argsort(np.where(mask == want, dist, np.inf))[:k]
                for name, want in (("unselected", False), ("selected", True))}
        out.append({"row": int(r), "beyond_dx": float(d[i] / w["dx"]), "rgb": rgb[r].round(2).tolist(),
                    "moves": float(moves[r]), "selection_moves_median": float(np.median(moves[rows])),
                    **{f"{n}_rgb": rgb[j].mean(axis=0).round(2).tolist() for n, j in near.items()},
                    **{f"{n}_moves": float(np.median(moves[j])) for n, j in near.items()}})
    return out


def simulate(scene_text: str, out: Path, frames: int | None = None) -> float:
    """Run ``gasp simulate`` on ``scene_text`` (its relative ``file`` paths read from the kitchen example's folder)
    into ``out``; wall seconds. The scene is written to a temporary folder of its own, never beside the example (a
    killed run left ``examples/_kitchen_wall_<pid>.toml`` there before round 61)."""
    import re
    text = re.sub(r'^(\s*file\s*=\s*")([^"/][^"]*)"', lambda m: f'{m.group(1)}{(KITCHEN.parent / m.group(2)).as_posix()}"',
                  scene_text, flags=re.M)
    cmd = [sys.executable, "-m", "gasp_core.cli.main", "simulate", "", "-o", str(out), "-q"]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "kitchen_wall.toml"
        scene.write_text(text)
        cmd[4] = str(scene)
        subprocess.run(cmd + (["--frames", str(frames)] if frames else []), check=True, cwd=ROOT)
    return time.perf_counter() - t0


def without_rest_collider(text: str) -> str:
    """The kitchen scene's text with ``rest_collider = false`` on its object (the ground plane alone)."""
    return text.replace("\nselect = ", "\nrest_collider = false\nselect = ", 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=None, help="folder for the two runs (default: a temporary one)")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="kitchen_wall_"))
    text = KITCHEN.read_text()
    rows = []
    for label, t in (("the pan as collider (default)", text), ("ground plane alone", without_rest_collider(text))):
        folder = out / ("rest" if t is text else "plane")
        wall_s = simulate(t, folder)
        m = measure(folder)
        rows.append(f"| {label} | {m['n']} | " + " | ".join(str(m["beyond"][c]) for c in CELLS)
                    + f" | {m['max_m'] * 100:.2f} ({m['max_m'] / m['dx']:.2f} dx) | {wall_s:.1f} |")
    load = os.getloadavg()[0]
    table = "\n".join([
        f"kitchen_spinach.toml, 30 frames, taichi_mpm, dx {m['dx'] * 1e3:.2f} mm; load average {load:.2f}",
        "",
        "| run | spinach Gaussians | beyond the wall | > 1/2 dx | > 1 dx | > 2 dx | farthest beyond, cm | wall s |",
        "|---|---|---|---|---|---|---|---|", *rows])
    left = who_left(out / "rest")
    table += "\n\nThe pan as collider: each spinach Gaussian beyond the wall beside its 10 nearest neighbours (`who_left`)\n\n"
    table += "| input row | beyond (dx) | colour | moves (file units) | unselected nbrs: colour, moves | " \
             "selected nbrs: colour, moves | the selection's median move |\n|---|---|---|---|---|---|---|\n"
    table += "\n".join(f"| {w['row']} | {w['beyond_dx']:.2f} | {w['rgb']} | {w['moves']:.3f} | {w['unselected_rgb']}, "
                        f"{w['unselected_moves']:.3f} | {w['selected_rgb']}, {w['selected_moves']:.3f} | "
                        f"{w['selection_moves_median']:.3f} |" for w in left)
    print(table)
    (ROOT / "benchmarks" / "results" / "kitchen_wall.md").write_text(
        "# The kitchen's spinach against the pan's wall (`python benchmarks/kitchen_wall.py`)\n\n" + table + "\n")


if __name__ == "__main__":
    main()
