import sys; sys.path.insert(0, "/tmp/b")
import numpy as np, warnings; warnings.simplefilter("ignore")
from mk import make
from gasp_core.scene.spec import load_scene
from gasp_core.prepare.scene import prepare_scene
from gasp_core.toolkit.contact import contact_table
def fit_sphere(p):
    A = np.column_stack([2 * p, np.ones(len(p))]); b = (p * p).sum(1)
    sol = np.linalg.lstsq(A, b, rcond=None)[0]; c = sol[:3]; return c, np.sqrt(sol[3] + c @ c)
for j in [0.0, 0.003]:
    s = prepare_scene(load_scene(make(contact="surface", jitter=j))).setup
    t = contact_table(s); car = t[:, 0] > 0
    com = (s.p_vol[:, None] * s.x).sum(0) / s.p_vol.sum()
    cs, rs = fit_sphere((s.x + t[:, 3:])[car])
    cv, rv = fit_sphere(s.x[:s.n_render:3])
    print(j, "CoM-geo(means) mm", np.round(1e3 * (com - cv), 3), "IMLS-carriers centre - means centre", np.round(1e3 * (cs - cv), 3), "radii", rs, rv, "n carriers", car.sum())
