"""Round 71 (lead; docs/fracture.md "Round 71 (lead): the midpoint stress symmetrised"): the free, spun, breathing
jelly ball of ``tests/test_stress_spin.py`` on taichi_mpm, its total energy (``benchmarks/energy_ledger.py``'s
``total``: kinetic, affine and stored, J) frame by frame, % of its start, under "start", the trapezoid with the whole
midpoint stress (``MidStress.symmetric`` False, rounds 68-70) and with its symmetric part (the default since round
71), at three spins. It showed the symmetric part gaining nothing against the whole stress.

Run: ``python benchmarks/studies/spin_energy.py`` (from the repository root; about 1 minute on 2 cores).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import energy_ledger as el  # noqa: E402

SPINS = ((1.5, 5.0, 0.0), (0.0, 0.0, 0.0), (1.5, 20.0, 0.0))   # rad/s; the breathing 2 (1, 0.5, -0.7) r at each


def run(at: str, symmetric: bool, frames: int = 8, w=(1.5, 5.0, 0.0), breath: float = 2.0) -> tuple[float, list]:
    """``(E0, [E(f) / E0 - 1 for f in 1..frames])`` of the free ball under ``stress_at = at`` (J, fractions)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup, sphere_points
    from gasp_taichi_mpm.mid_stress import MidStress
    MidStress.symmetric = symmetric
    MidStress.symmetric = sym
    n, side = 24, 0.3
    dx = side / n
    x, p_vol = sphere_points(np.array([0.003, -0.002, 0.001]), 0.05, dx / 2)
    r = x - x.mean(0)
    v = np.cross(np.array(w), r) + breath * r * np.array([1.0, 0.5, -0.7])
    mat = Material("jelly", E=2e4, nu=0.3, rho=300.0)
    s = make_setup(x, p_vol, mat, v=v, lo=(-0.15,) * 3, hi=(0.15,) * 3, n_grid=n, boundaries=[],
                   options={"stress_at": at})
    s.gravity = np.zeros(3)
    e = build_engine(engines()["taichi_mpm"], s)
    L = el.Ledger(s, e, mat, ground=None)
    E0 = el.total(L.energy(L.steps.points()))
    out = []
    for _ in range(frames):
        e.step_frame()
        out.append(el.total(L.energy(L.steps.points())) / E0 - 1)
    e.close()
    return E0, out


if __name__ == "__main__":
    for w in SPINS:
        for at, sym in (("start", True), ("trapezoid", False), ("trapezoid", True)):
            E0, out = run(at, sym, w=w)
            print(f"spin {w} {at:9s} symmetric={sym}: E0 {E0:.4e} J; E/E0 - 1, % by frame:",
                  " ".join(f"{100 * o:+.3f}" for o in out), flush=True)
