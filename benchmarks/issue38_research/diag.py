import sys; sys.path.insert(0, "/tmp/b"); sys.path.insert(0, "/work/main/benchmarks")
import numpy as np, warnings, tempfile
from pathlib import Path
import contact_mustshow as cm
from gasp_core.scene.spec import load_scene
from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.build import build_engine
def omega(e, s):
    x = e.positions().astype(float); v = e.velocities().astype(float); m = s.p_mass
    c = (m[:, None] * x).sum(0) / m.sum(); vc = (m[:, None] * v).sum(0) / m.sum()
    r = x - c; L = (m[:, None] * np.cross(r, v - vc)).sum(0)
    I = (m[:, None, None] * ((r * r).sum(1)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])).sum(0)
    return np.linalg.solve(I, L)
def diag(contact="surface", jitter=0.0, drop=0.05, E=2e4, friction=0.0, frames=12, engine="warp_mpm", n_grid=16, setup_hook=None, seed_rot=None):
    d = Path(tempfile.mkdtemp()); ply = cm.ball(d / "b.ply", jitter)
    txt = (cm.scene(ply, engine, contact).replace("E = 2.0e4", f"E = {E:g}").replace("friction = 0.5", f"friction = {friction}")
           .replace("n_grid = 16", f"n_grid = {n_grid}").replace(f"position = [0.0, 0.0, {cm.RADIUS + cm.DROP}]", f"position = [0.0, 0.0, {cm.RADIUS + drop}]"))
    (d / "s.toml").write_text(txt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(d / "s.toml"))
        if setup_hook: setup_hook(ps.setup)
        e = build_engine(ps.info, ps.setup)
    out = []
    for f in range(frames):
        e.step_frame(); out.append(np.linalg.norm(omega(e, ps.setup)))
    return np.round(out, 3)
if __name__ == "__main__":
    for c in sys.argv[1].split(","):
        for j in [0.0, 0.003]:
            print(c, j, diag(c, j), flush=True)
