import sys, time, numpy as np, warnings; warnings.simplefilter("ignore")
sys.path.insert(0, "/tmp/b")
from run import kabsch
from gasp_core.scene.spec import load_scene
from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.build import build_engine
c = sys.argv[1]; frames = int(sys.argv[2]); path = sys.argv[3] if len(sys.argv) > 3 else "examples/donut_jelly.toml"
ps = prepare_scene(load_scene(path), options=None)
s = ps.setup; s.options["contact"] = c
e = build_engine(ps.info, s); n = s.n_render
x0 = e.positions()[:n]; t0 = time.time()
for f in range(frames):
    e.step_frame(); x = e.positions()[:n]; d = x.mean(0) - x0.mean(0)
    print(c, f + 1, f"drift {1e3*np.hypot(d[0], d[1]):.2f} mm ang {kabsch(x0, x):.2f} zmin {x[:,2].min()/s.dx:+.3f} dx  t {time.time()-t0:.0f}", flush=True)
