"""The elastic stress concentration ``Kt`` of a flat dog-bone's shoulder, by a body-fitted plane-stress finite-element
solve (issue 66, "Tension, over a family"; ``benchmarks/tension_family.py``'s dog-bones, docs/fracture.md).

With ``nu = 0`` a flat specimen (its width ``w(x)`` along y varying, its thickness constant) is exactly plane stress:
the 3-D field has ``sigma_zz = sigma_xz = sigma_yz = 0``, so this 2-D solve is the continuum's answer for the family's
flat dog-bones, free of any point fill or grid. A quarter model (symmetric about the gauge's middle and the axis),
bilinear quadrilaterals mapped to the outline (each column of nodes spread evenly over the local half-width), the
grip's end pulled by a uniform displacement. ``Kt`` is the largest principal stress anywhere (Gauss points
extrapolated to the nodes, averaged over the elements at each node) over the gauge's uniform ``sigma_xx``.

Reference for the trend: W. D. Pilkey, D. F. Pilkey, "Peterson's Stress Concentration Factors", 3rd ed., Wiley 2008,
chapter 3 (shoulder fillets in tension: ``Kt`` falls toward 1 as the fillet's radius over the narrow width ``r / d``
grows). Run: ``python benchmarks/shoulder_kt.py`` (each family dog-bone at two meshes).

:func:`engine_field` measures the same in an MPM engine's own elastic field (``f_t`` raised so nothing damages):
``python benchmarks/shoulder_kt.py --engine taichi_mpm --n-grid 24`` (one engine per process).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spl

G = 1 / np.sqrt(3)
GAUSS = [(-G, -G), (G, -G), (G, G), (-G, G)]


def _dN(xi: float, eta: float) -> np.ndarray:
    """The bilinear shape functions' derivatives (2, 4) at (xi, eta), corners counter-clockwise from (-1, -1)."""
    return 0.25 * np.array([[-(1 - eta), 1 - eta, 1 + eta, -(1 + eta)],
                            [-(1 - xi), -(1 + xi), 1 + xi, 1 - xi]])


def solve(half_width, x_end: float, d: float, nx: int, ny: int, nu: float = 0.0) -> dict:
    """The quarter dog-bone ``0 <= x <= x_end`` (x from the gauge's middle, m), ``0 <= y <= half_width(x)``; ``nx`` by
    ``ny`` elements. Returns ``{"kt", "x_max", "y_max", "sigma_gauge"}`` (E = 1, end displacement 1e-3 x_end):
    ``kt`` the largest nodal principal stress over the gauge's ``sigma_xx`` at (0, 0), where it is (m)."""
    xs = np.linspace(0.0, x_end, nx + 1)
    hw = half_width(xs)
    X = np.repeat(xs[:, None], ny + 1, 1)
    Y = hw[:, None] * np.linspace(0.0, 1.0, ny + 1)[None, :]
    nid = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    el = np.stack([nid[:-1, :-1], nid[1:, :-1], nid[1:, 1:], nid[:-1, 1:]], -1).reshape(-1, 4)
    xy = np.stack([X.ravel(), Y.ravel()], 1)
    Dm = np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]]) / (1 - nu ** 2)
    ce = xy[el]                                                          # (ne, 4, 2)
    K = np.zeros((len(el), 8, 8))
    Bs = []
    for xi, eta in GAUSS:
        dn = _dN(xi, eta)
        J = np.einsum("ak,ekb->eab", dn, ce)                             # (ne, 2, 2)
        dndx = np.einsum("eab,bk->eak", np.linalg.inv(J), dn)            # (ne, 2, 4)
        B = np.zeros((len(el), 3, 8))
        B[:, 0, 0::2], B[:, 1, 1::2] = dndx[:, 0], dndx[:, 1]
        B[:, 2, 0::2], B[:, 2, 1::2] = dndx[:, 1], dndx[:, 0]
        K += np.einsum("eia,ij,ejb,e->eab", B, Dm, B, np.linalg.det(J))
        Bs.append(B)
    dof = np.stack([2 * el, 2 * el + 1], -1).reshape(-1, 8)
    n = 2 * len(xy)
    Kg = sps.csr_matrix((K.ravel(), (np.repeat(dof, 8, 1).ravel(), np.tile(dof, (1, 8)).ravel())), shape=(n, n))
    u = np.zeros(n)
    fixed = np.concatenate([2 * nid[0], 2 * nid[-1], 2 * nid[:, 0] + 1])    # u = 0 mid, u = set end, v = 0 axis
    u[2 * nid[-1]] = 1e-3 * x_end
    free = np.setdiff1d(np.arange(n), fixed)
    u[free] = spl.spsolve(Kg[free][:, free].tocsc(), -Kg[free][:, fixed] @ u[fixed])
    ue = u[dof]
    sg = np.stack([np.einsum("ij,ejb,eb->ei", Dm, B, ue) for B in Bs], 1)   # (ne, 4 Gauss, 3)
    a, b = 1 + np.sqrt(3) / 2, -0.5
    c = 1 - np.sqrt(3) / 2
    ext = np.array([[a, b, c, b], [b, a, b, c], [c, b, a, b], [b, c, b, a]])   # Gauss -> corners
    sn = np.einsum("kg,egi->eki", ext, sg)
    acc = np.zeros((len(xy), 3))
    cnt = np.zeros(len(xy))
    np.add.at(acc, el.ravel(), sn.reshape(-1, 3))
    np.add.at(cnt, el.ravel(), 1)
    s = acc / cnt[:, None]
    s1 = 0.5 * (s[:, 0] + s[:, 1]) + np.sqrt((0.5 * (s[:, 0] - s[:, 1])) ** 2 + s[:, 2] ** 2)
    ref = s[nid[0, 0], 0]
    k = int(np.argmax(s1))
    return {"kt": float(s1[k] / ref), "x_max": float(xy[k, 0]), "y_max": float(xy[k, 1]), "sigma_gauge": float(ref)}


def kt_of(sp, per_d: int) -> dict:
    """``Kt`` of the dog-bone ``sp`` (a ``tension_family.Specimen``) at ``per_d`` elements across its half gauge
    width (and as many per ``d / 2`` along x); x from the gauge's middle to 2 ``grip`` past the shoulder."""
    import tension_family as tf
    mid = tf.X0 + sp.length / 2
    x_end = sp.gauge_l / 2 + sp.shoulder() + 2 * sp.grip
    h = sp.gauge_w / 2 / per_d
    r = solve(lambda x: sp.width(mid + x) / 2, x_end, sp.gauge_w, int(np.ceil(x_end / h)), per_d)
    r["x_max_past_gauge"] = r["x_max"] - sp.gauge_l / 2
    return r


def engine_field(sp, n_grid: int, engine: str, partial: bool = True) -> dict:
    """The dog-bone ``sp`` on ``engine`` at ``n_grid`` (``tension_family.build``; ``partial``: the fill's cut cubes,
    else whole lattice cubes, a staircase), stretched elastically (f_t and G_f raised 100x and 5e4x) until its gauge
    carries about f_t, then read: ``kt_full`` the largest principal Kirchhoff stress of the points of at least half
    a lattice cube's volume, ``kt_any`` of every point, both over the gauge's median nominal stress; ``at`` the rest
    x (m) of the first, past the nominal gauge's nearer end; ``layer_spread`` the largest ``|F_layer / F_gauge - 1|``
    over the free layers (each layer's force ``sum P_xx`` over its section, which equilibrium makes equal)."""
    import tension_family as tf
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    gf = tf.GF
    tf.GF = 1e6
    try:
        st, layer, lx, clamp, pulled = tf.build(sp, n_grid, engine, ft=100 * tf.FT, partial=partial)
    finally:
        tf.GF = gf
    s, nl, ag = st.dx / 2, len(lx), sp.gauge_w ** 2
    comp = np.cumsum(ag / sp.area(lx))
    t_ft = (tf.FT / tf.E) * (np.interp(pulled, lx, comp) - np.interp(clamp, lx, comp)) * s / tf.PULL
    e = build_engine(engines()[engine], st)
    try:
        for _ in range(int(round(t_ft / tf.FRAME_DT))):
            e.step_frame()
        F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
    finally:
        e.close()
    smax = tf.E * np.log(np.linalg.svd(F, compute_uv=False)).max(axis=1)      # nu 0: tau_i = E eps_i
    wgt = np.asarray(st.p_vol, np.float64) / s ** 3
    force = np.bincount(layer, tf.nominal_xx(F, np.zeros(len(F))) * wgt, nl) * s * s
    g_lo, g_hi = sp.gauge(st.dx)
    ref = np.median(force[(lx > g_lo) & (lx < g_hi)]) / ag
    inner = (lx[layer] > clamp + 2 * st.dx) & (lx[layer] < pulled - 2 * st.dx)
    full = inner & (wgt >= 0.5)
    k = np.flatnonzero(full)[np.argmax(smax[full])]
    xk = float(st.x[k, 0])
    free = (lx > clamp + 2 * st.dx) & (lx < pulled - 2 * st.dx)
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "partial": partial,
            "kt_full": float(smax[k] / ref), "kt_any": float(smax[inner].max() / ref),
            "at": min(abs(xk - g_lo), abs(xk - g_hi)) * (1 if not g_lo < xk < g_hi else -1),
            "layer_spread": float(np.abs(force[free] / (ref * ag) - 1).max()), "gauge_stress": float(ref)}


def main() -> None:
    import argparse
    import tension_family as tf
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="", help="an MPM engine: its own field, else the finite elements")
    ap.add_argument("--n-grid", type=int, default=24)
    a = ap.parse_args()
    bones = [s for s in tf.FAMILY + tf.OLD_BONES if s.gauge_l > 0]
    if a.engine:
        for sp in bones:
            for partial in (True, False):
                r = engine_field(sp, a.n_grid, a.engine, partial)
                print(f"{sp.name} {a.engine} n_grid {a.n_grid} {'cut cubes' if partial else 'staircase'}: Kt "
                      f"{r['kt_full']:.3f} (points of half a cube or more), {r['kt_any']:.3f} (any), at "
                      f"{r['at']:+.4f} m past the gauge's end; layer forces within {100 * r['layer_spread']:.1f} %",
                      flush=True)
        return
    for sp in bones:
        for per_d in (16, 32):
            r = kt_of(sp, per_d)
            print(f"{sp.name}: {per_d} elements across d/2: Kt {r['kt']:.4f} at {r['x_max_past_gauge']:+.4f} m "
                  f"past the gauge's end, y {r['y_max']:.4f}{'' if sp.flat else ' (a square section: 2-D only)'}",
                  flush=True)


if __name__ == "__main__":
    main()
