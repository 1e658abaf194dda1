"""A soft ball (material argv) at speed onto a rigid box on the ground: the box's speed after 1 frame at fixed n_substeps.

Round 59 (docs/contact.md "Round 59: AFLIP's old velocity per field"): the lead's repro of the fine-step blow-up.
Usage: ``python benchmarks/studies/finestep_pair.py taichi_mpm "[dict(opts={'n_substeps': 400}, rigid=False,
speed=0.0)]"`` (kwargs of :func:`scene`); prints ``(box speed m/s, ball's mean z m, n_substeps)`` per case.
"""
import sys, ast, numpy as np
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points

def scene(ball="jelly", speed=5.0, opts=None, n_grid=32, rigid=True, ground=True):
    dx = 0.6 / n_grid; s = dx / 2
    xb, vb = box_points((-0.06, -0.06, 0.0), (0.06, 0.06, 0.06), s)
    g = np.mgrid[-0.05:0.05:s, -0.05:0.05:s, -0.05:0.05:s].reshape(3, -1).T + s / 2
    xs = g[np.linalg.norm(g, axis=1) <= 0.05] + np.array([0.0, 0.0, 0.065 + 0.05])
    x = np.vstack([xb, xs])
    box = Material("jelly", E=1e10, rho=700.0, model="rigid") if rigid else Material("jelly", E=1e5, rho=700.0)
    mats = [box, Material(ball)]
    v = np.zeros_like(x); v[len(xb):, 2] = -speed
    return SimSetup(x=x, v=v, p_vol=np.full(len(x), s ** 3), body_id=np.r_[np.zeros(len(xb), int), np.ones(len(xs), int)],
                    materials=mats, gravity=np.array([0, 0, -9.81]), domain_lo=np.array([-0.3, -0.3, -0.02]),
                    domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=n_grid,
                    boundaries=[Boundary("ground", height=0.0, friction=0.5)] if ground else [], frame_dt=1 / 30,
                    options=dict(opts or {})), len(xb)

def box_speed(eng, frames=1, **kw):
    st, nb = scene(**kw)
    e = build_engine(engines()[eng], st)
    try:
        for _ in range(frames):
            e.step_frame()
        v = np.asarray(e.velocities(), float); x = np.asarray(e.positions(), float)
        return float(np.linalg.norm(v[:nb].mean(0))), float(x[nb:, 2].mean()), e.stats()["n_substeps"]
    except Exception as ex:
        return "ERR " + str(ex)[:80], None, None
    finally:
        e.close()

if __name__ == "__main__":
    eng = sys.argv[1]
    for kw in eval(sys.argv[2]):
        print(kw, box_speed(eng, **kw), flush=True)
