import sys; sys.path.insert(0, "/tmp/b")
from diag import diag
import numpy as np
def recentre(s, target=None):
    x = s.x; v = np.array(s.p_vol, dtype=float); mat = v > 0
    geo = x[:s.n_render:3].mean(0) if target is None else target   # centre of the surface points
    c = (v[:, None] * x).sum(0) / v.sum()
    # v' = v (1 + g.(x - c)): sum v' = sum v; sum v' x = sum v x + M2 g  with M2 = sum v (x-c)(x-c)^T
    r = x - c; M2 = (v[:, None, None] * r[:, :, None] * r[:, None, :]).sum(0)
    g = np.linalg.solve(M2, v.sum() * (geo - c))
    s.p_vol = v * (1 + r @ g)
    print("com shift mm", 1e3 * (geo - c), "min factor", (1 + r @ g).min())
for c in sys.argv[1].split(","):
    for j in [0.0, 0.003]:
        print(c, j, diag(c, j, setup_hook=recentre), flush=True)
