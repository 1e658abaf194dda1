"""Round 80's slow coarse roll traced (warp_mpm only; ``docs/rigid.md`` "Round 80"): where the booking leaks.

The slope scene of ``roll_cylinder.py`` at n_grid 24 (the slab 3 cm = 1.5 dx thick on a ground of friction 1).
``budget``: per substep, the body's x-impulse and y-moment about its centre split into the contact's reaction (what
the point/roll contact adds to ``acc_p``/``acc_l`` before G2P) and the body's own field's departure from its exact
rigid field at G2P (``I w0 + booking``), and where that departure sits (node layer below the centre).
``fix``: rounds 41-43's ``B_FRICTION`` (the particle contact's ground friction at a node shared by the two fields
given to field B alone; today only in ``"mixed"`` scenes) switched on for this non-mixed scene by re-pointing the
recorded ``grid_update``'s ``grid_mf`` (field A's mass at the shared nodes, from ``pc_m``), ``grid_dv`` and ``rule``
(an experiment, not the engines' code). Round 81 made it the engines' rule (``gasp_core.mpm.fields.RIGID_A_FRICTION``,
``--fix 0``'s bits: on the mean velocity; ``docs/rigid.md`` "Round 81"); set it False to see the study's own patch.

    python benchmarks/studies/roll_leak80.py budget 1      # SPIN_BOOKED 1 / 0
    python benchmarks/studies/roll_leak80.py slope 1 0.03 0.06 --fix 0   # rule bits for the fix (0: B_FRICTION only)
    python benchmarks/studies/roll_leak80.py rest 1 0.03 0.06 --fix 0
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _names(e):
    return [getattr(getattr(c, "kernel", None), "key", type(c).__name__).split("__locals__")[-1] for c in e._launches]


class _Fill:
    """Before ``grid_update``: field A's node mass where both fields have mass (from ``pc_m``) into ``arr``."""

    def __init__(self, e, arr):
        self.e, self.arr, self.nn = e, arr, e.n_grid ** 3

    def launch(self):
        pm, nn = self.e.pc_m.numpy().astype(np.float64), self.nn
        ma, mb = pm[:nn], pm[nn:2 * nn]
        self.arr.assign(np.where((ma > 0) & (mb > 0), ma, 0.0).astype(self.arr.numpy().dtype))


def patch_engine(rule: int | None):
    """``roll_neighbours._engine`` with the ``B_FRICTION`` extension (``rule`` None: unpatched)."""
    import warp as wp
    import roll_cylinder
    import roll_neighbours
    orig = roll_neighbours._engine

    def patched(engine, s, roll):
        e = orig(engine, s, roll)
        if rule is not None:
            assert int(e.in_a.numpy()[0]) == 1   # the rigid body in field A
            i = _names(e).index("grid_update")
            arr = wp.zeros(e.n_grid ** 3, dtype=e.grid_mf.dtype, device=e.device)
            e._launches[i].set_param_by_name("grid_mf", arr)
            e._launches[i].set_param_by_name("grid_dv", e.grid_dv)
            e._launches[i].set_param_by_name("rule", int(rule))
            e._launches.insert(i, _Fill(e, arr))
        return e

    roll_neighbours._engine = roll_cylinder._engine = patched
    return patched


def budget(frames=(12, 48), R=0.03, L=0.06, rule=None) -> dict:
    from roll_neighbours import slab_setup
    make = patch_engine(rule)
    s = slab_setup(24, [("cyl6" if L else "ball", R, (-0.06, 0.0), 0.0, 0.0)], mu=0.5, theta=20.0)
    e = make("warp_mpm", s, True)
    names = _names(e)
    n, dx, dt, g = e.n_grid, e.dx, e.dt, np.asarray(s.gravity, float)
    nn = n ** 3
    idx = np.arange(nn)
    X = np.asarray(s.domain_lo, float) + dx * np.stack([idx // (n * n), (idx // n) % n, idx % n], 1)
    M, Iy = float(e.rb_M.numpy()[0]), float(e.rb_I0.numpy()[0][1, 1])
    for _ in range(frames[0]):
        e.step_frame()
    rows, layers = [], {}
    for _ in range(8 * (frames[1] - frames[0])):
        c0, V0, w0 = (a.numpy()[0].astype(float) for a in (e.rb_c, e.rb_V, e.rb_w))
        r = X - c0
        for i, cmd in enumerate(e._launches):
            if names[i] == "g2p":
                pc, lc = e.acc_p.numpy()[0].astype(float), e.acc_l.numpy()[0].astype(float)
                m = e.pc_m.numpy()[:nn].astype(float)
                v = e.grid_v.numpy().astype(float) + e.grid_dv.numpy()[:nn].astype(float)
                dP = m[:, None] * (v - (V0 + g * dt + np.cross(w0, r)))
                dL = np.cross(r, dP)
                kz = np.round(r[:, 2] / dx).astype(int)
                for k in np.unique(kz[m > 0]):
                    layers[k] = layers.get(k, 0.0) + np.array([dP[kz == k, 0].sum(), dL[kz == k, 1].sum()])
            cmd.launch()
        w1, V1 = e.rb_w.numpy()[0].astype(float), e.rb_V.numpy()[0].astype(float)
        Lr = lc - np.cross(c0, pc)
        rows.append([pc[0], Lr[1], dP[:, 0].sum(), dL[:, 1].sum(), M * (V1[0] - V0[0]), Iy * (w1[1] - w0[1])])
    e.close()
    a = np.mean(rows, 0)
    out = {"contact_Jx": a[0], "contact_Ly": a[1], "field_dPx": a[2], "field_dLy": a[3], "M_dV": a[4], "I_dw": a[5],
           "gravity_x": M * g[0] * dt, "lever_total": a[5] / (a[4] - M * g[0] * dt), "R": R,
           "layers": {int(k): (v / len(rows)).tolist() for k, v in sorted(layers.items()) if np.abs(v).max() > 0}}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", choices=["budget", "slope", "rest"])
    ap.add_argument("booked", type=int)
    ap.add_argument("R", type=float, nargs="?", default=0.03)
    ap.add_argument("L", type=float, nargs="?", default=0.06)
    ap.add_argument("--fix", type=int, default=None, help="the B_FRICTION extension with these rule bits")
    a = ap.parse_args()
    import gasp_core.mpm.spin_booking as sb
    sb.SPIN_BOOKED = bool(a.booked)
    if a.scene == "budget":
        r = budget(R=a.R, L=a.L, rule=a.fix)
    else:
        patch_engine(a.fix)
        import roll_cylinder
        r = (roll_cylinder.slope("warp_mpm", 24, a.R, a.L, 0.5) if a.scene == "slope"
             else roll_cylinder.rest("warp_mpm", 24, a.R, a.L, T=1.5))
    print(a.scene, a.booked, a.R, a.L, "fix", a.fix, {k: (round(float(v), 8) if np.isscalar(v) else v)
                                                     for k, v in r.items()})


if __name__ == "__main__":
    main()
