import sys, tempfile
from pathlib import Path
sys.path.insert(0, "benchmarks")
import contact_mustshow as cm
def make(engine="warp_mpm", contact="particle", jitter=0.0, drop=None, n_grid=16, extra=""):
    d = Path(tempfile.mkdtemp())
    ply = cm.ball(d / "ball.ply", jitter)
    s = cm.scene(ply, engine, contact)
    if drop is not None:
        s = s.replace(f"position = [0.0, 0.0, {cm.RADIUS + cm.DROP}]", f"position = [0.0, 0.0, {cm.RADIUS + drop}]")
    s = s.replace("n_grid = 16", f"n_grid = {n_grid}") + extra
    t = d / "s.toml"; t.write_text(s); return t
