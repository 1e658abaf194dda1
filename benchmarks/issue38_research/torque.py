import sys; sys.path.insert(0, "/tmp/b"); sys.path.insert(0, "/work/main/benchmarks")
import numpy as np, warnings, tempfile
from pathlib import Path
import contact_mustshow as cm
from gasp_core.scene.spec import load_scene
from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.build import build_engine
def run(contact, jitter, steps=180, E=2e4, hook=None):
    d = Path(tempfile.mkdtemp()); ply = cm.ball(d / "b.ply", jitter)
    txt = cm.scene(ply, "warp_mpm", contact).replace("friction = 0.5", "friction = 0.0").replace("frame_dt = 0.0333333", "frame_dt = 0.00104166").replace("n_frames = 40", "n_frames = 400").replace("E = 2.0e4", f"E = {E:g}")
    (d / "s.toml").write_text(txt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(d / "s.toml"))
        if hook: hook(ps.setup)
        e = build_engine(ps.info, ps.setup)
    print("substeps", e.n_substeps, e.dt)
    m = e.p_mass.numpy().astype(float); vol = e.p_vol.numpy().astype(float); fill = vol >= vol.max() * 0.99
    kcs = e.p_contact.numpy().astype(float); off = e.p_offset.numpy().astype(float)
    Lc = np.zeros((2, 2)); Jt = 0; Lsum = np.zeros(2)
    for st in range(steps):
        m = e.p_mass.numpy().astype(float); vol = e.p_vol.numpy().astype(float); fill = vol >= vol.max() * 0.99
        kcs = e.p_contact.numpy().astype(float); off = e.p_offset.numpy().astype(float)
        x = e.x.numpy().astype(float); v = e.v.numpy().astype(float); F = e.F.numpy().astype(float); C = e.C.numpy().astype(float)
        Fn = np.einsum("pij,pjk->pik", np.eye(3) + e.dt * C, F)
        zs = x[:, 2] + np.einsum("pj,pj->p", Fn[:, 2, :], off)
        depth = 0.0 + kcs[:, 2] - zs
        j = np.where(depth > 0, np.maximum(e.dt * (kcs[:, 0] * depth - kcs[:, 1] * v[:, 2]), 0), 0)
        c = (m[:, None] * x).sum(0) / m.sum()
        r = x - c
        # torque of vertical impulse: (r x z j) = (r_y j, -r_x j)
        for k, sel in enumerate([fill, ~fill]):
            Lc[k] += [(r[sel, 1] * j[sel]).sum(), -(r[sel, 0] * j[sel]).sum()]
        Jt += j.sum()
        e.step_frame()
    m = e.p_mass.numpy().astype(float); x = e.x.numpy().astype(float); v = e.v.numpy().astype(float)
    c = (m[:, None] * x).sum(0) / m.sum(); vc = (m[:, None] * v).sum(0) / m.sum(); r = x - c
    L = (m[:, None] * np.cross(r, v - vc)).sum(0)
    print(contact, jitter, "J", round(Jt, 4), "contact L (fill, vertex)", Lc, "actual L", L[:2], "lever mm fill/vert", 1e3 * Lc[0] / Jt, 1e3 * Lc[1] / Jt)
for c in sys.argv[1].split(","):
    for j in [0.0, 0.003]:
        run(c, j)
