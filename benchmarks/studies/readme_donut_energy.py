"""Round 71 (docs/fracture.md "Round 71: the slow tiers under the trapezoid default"): the README donut
(``examples/donut_jelly.toml``, as the quick start runs it) frame by frame under ``stress_at = AT``: the Gaussians'
mean height (``tests/test_examples.py``'s ``test_readme_donut_run`` reads it from the frame files), the engine points'
kinetic, gravitational (over z = 0) and stored (fixed corotated) energy and their sum, J, and the mean vertical
speed. It showed that the resting donut's frame maxima rise while its energy falls (the check then read the flights
alone).

Run: ``python benchmarks/studies/readme_donut_energy.py ENGINE AT [FRAMES]`` (one JSON line a frame; FRAMES 36).
"""
from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def main(argv: list[str]) -> int:
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    engine, at = argv[0], argv[1]
    frames = int(argv[2]) if len(argv) > 2 else 36
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(ROOT / "examples" / "donut_jelly.toml"), engine)
        setup = ps.setup.replace(options={**ps.setup.options, "stress_at": at})
        e = build_engine(engines()[engine], setup)
    mat = setup.materials[0]
    lam, mu = mat.E * mat.nu / ((1 + mat.nu) * (1 - 2 * mat.nu)), mat.E / (2 * (1 + mat.nu))
    rho = np.array([m.rho for m in setup.materials])[np.asarray(setup.body_id)]
    vol = np.broadcast_to(np.asarray(setup.p_vol, np.float64), rho.shape)

    def row(f: int) -> None:
        z = float(np.asarray(e.positions())[:setup.n_render, 2].mean())
        if engine == "warp_mpm":     # internal order: the engine's own mass and volume
            pm, pv = e.read_array("p_mass"), e.read_array("p_vol")
        else:
            pm, pv = vol * rho, vol
        v, x = e.read_array("v"), e.read_array("x")
        s = np.linalg.svd(e.read_array("F").reshape(-1, 3, 3), compute_uv=False)
        ke = 0.5 * float((pm * (v ** 2).sum(1)).sum())
        pe = float((pm * 9.81 * x[:, 2]).sum())
        el = float((pv * (mu * ((s - 1) ** 2).sum(1) + 0.5 * lam * (s.prod(1) - 1) ** 2)).sum())
        print(json.dumps({"frame": f, "z_mean_mm": round(z * 1e3, 3), "kinetic": ke, "gravity": pe, "stored": el,
                          "total": ke + pe + el, "vz": float((pm * v[:, 2]).sum() / pm.sum())}), flush=True)

    try:
        row(0)
        for f in range(1, frames + 1):
            e.step_frame()
            row(f)
    finally:
        e.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
