"""The oblique dog-bones' elastic field under their holds, by a continuum solver (issue 66, round 40;
docs/fracture.md "Round 40: the oblique peak is the holds' bending").

``tension_oblique.py`` holds a specimen at an angle to the grid by the half-spaces ``x <= c`` (fixed) and ``x >= c'``
(pulled along the axis ``a``). Each face crosses the section obliquely, so the fibres at the two thickness faces
(``y' = +-t/2``, ``y'`` the in-plane normal to the axis) are held over lengths that differ by ``t tan(theta)``. A
uniform stretch would shear the held parts; they are rigid, so the gauge carries a transverse shear force and a
bending moment that varies linearly along it, and its surfaces' axial strain spreads about the median.

This module solves that by linear plane-stress finite elements (bilinear quads, 2 x 2 Gauss points, E 1, nu 0, the
thickness along z' the specimen's width ``w(s)``; T. J. R. Hughes, "The Finite Element Method", Dover 2000, ch. 3),
in the specimen's (axial ``s``, ``y'``) plane, nodes whose grid x is at or past a face held as the engines hold the
points there, the pulled ones displaced along ``a + beta n`` (``n = R e_y``). Independent of the MPM engines, it
tells the continuum's share of the spread the engines show; :func:`free_drift` gives the ``beta`` for which the pulled
grip carries no transverse force (a grip free to slide across the axis, as a self-aligning grip does: ASTM E1012 on
bending in tension specimens), and ``tension_oblique.build(..., grip="free")`` pulls along ``a + beta n``.

Run: ``python benchmarks/oblique_grip.py`` (no engine, about 10 s); writes ``results/oblique_grip.{md,json}``.
"""
from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

import tension_family as tf

RESULTS = Path(__file__).parent / "results"
H = 0.0025          # the elements' side (m): 1/20 of a cell at n_grid 24


def faces(sp: tf.Specimen, angle: str, n_grid: int) -> tuple[float, float, np.ndarray]:
    """``tension_oblique.build``'s held faces: ``(clamp x, pulled x, R (3, 3))`` (m, the grid's frame)."""
    import tension_oblique as to
    xl, _, _, _ = to.local_lattice(sp, tf.SIZE / n_grid / 2)
    R = to.axis_frame(angle)
    mid = np.array([sp.length / 2, 0.0, 0.0])
    ext = np.abs(xl[:, 1:]).max(axis=0)
    corners = np.array([[0, sy * ext[0], sz * ext[1]] for sy in (-1, 1) for sz in (-1, 1)])
    grid = lambda q: to.CENTRE + (q - mid) @ R.T              # noqa: E731
    return (float(grid(corners + [tf.HOLD, 0, 0])[:, 0].max()),
            float(grid(corners + [sp.length - tf.HOLD, 0, 0])[:, 0].min()), R)


def _stiffness(sp: tf.Specimen, ns: int, ny: int):
    """The global stiffness (csr, 2 dofs a node, node ``i * (ny + 1) + j``) and each element's dofs (n_el, 8)."""
    import scipy.sparse as sps
    nid = np.arange((ns + 1) * (ny + 1)).reshape(ns + 1, ny + 1)
    el = np.stack([nid[:-1, :-1], nid[1:, :-1], nid[1:, 1:], nid[:-1, 1:]], -1).reshape(-1, 4)
    thick = np.repeat(sp.width(tf.X0 + (np.arange(ns) + 0.5) * H), ny)
    D = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 0.5]])          # E 1, nu 0, plane stress
    g = 1 / np.sqrt(3)
    Ke = np.zeros((8, 8))
    for xi, eta in [(-g, -g), (g, -g), (g, g), (-g, g)]:
        dN = 0.5 / H * np.array([[-(1 - eta), 1 - eta, 1 + eta, -(1 + eta)], [-(1 - xi), -(1 + xi), 1 + xi, 1 - xi]])
        B = np.zeros((3, 8))
        B[0, 0::2], B[1, 1::2], B[2, 0::2], B[2, 1::2] = dN[0], dN[1], dN[1], dN[0]
        Ke += B.T @ D @ B * (H / 2) ** 2
    dof = np.stack([2 * el, 2 * el + 1], -1).reshape(-1, 8)
    K = sps.csr_matrix(((Ke[None] * thick[:, None, None]).ravel(), (np.repeat(dof, 8, 1).ravel(),
                                                                     np.tile(dof, (1, 8)).ravel())),
                       shape=(2 * nid.size,) * 2)
    return K, dof


@lru_cache(maxsize=32)
def elastic_field(sp: tf.Specimen, angle: str, n_grid: int = 24, beta: float = 0.0) -> dict:
    """The plane-stress field of ``sp`` at ``angle`` under ``tension_oblique.build``'s holds, the pulled end displaced
    1e-3 m along ``a + beta n``. Returns ``{"centre": (n_el, 2) element centres (s, y') m, "emax": (n_el,) largest
    principal strain over the gauge's median axial strain, "exx": the axial strain so, "gauge": (n_el,) bool,
    "reaction": (2,) the pulled grip's force along a and n (N at E 1 Pa), "u": (ns + 1, ny + 1, 2) the nodes'
    displacement (m) along a and n}``, cached (do not modify it). Raises nothing; ``beta`` is free."""
    import scipy.sparse.linalg as spl
    ns, ny = int(round(sp.length / H)), int(round(sp.gauge_w / H))
    K, dof = _stiffness(sp, ns, ny)
    S, Y = np.meshgrid(np.linspace(0, sp.length, ns + 1), np.linspace(-sp.gauge_w / 2, sp.gauge_w / 2, ny + 1),
                       indexing="ij")
    clamp, pulled, R = faces(sp, angle, n_grid)
    import tension_oblique as to
    xg = to.CENTRE[0] + (S.ravel() - sp.length / 2) * R[0, 0] + Y.ravel() * R[0, 1]
    u = np.zeros(K.shape[0])
    fixed = np.zeros(K.shape[0], bool)
    pull = np.flatnonzero(xg >= pulled - 1e-12)
    for idx in (np.flatnonzero(xg <= clamp + 1e-12), pull):
        fixed[2 * idx] = fixed[2 * idx + 1] = True
    u[2 * pull], u[2 * pull + 1] = 1e-3, 1e-3 * beta
    free = ~fixed
    u[free] = spl.spsolve(K[free][:, free].tocsc(), -K[free][:, fixed] @ u[fixed])
    f = K @ u
    ue = u[dof]
    dN = 0.5 / H * np.array([[-1, 1, 1, -1], [-1, -1, 1, 1]])
    exx, eyy = ue[:, 0::2] @ dN[0], ue[:, 1::2] @ dN[1]
    gxy = ue[:, 0::2] @ dN[1] + ue[:, 1::2] @ dN[0]
    centre = np.stack([np.repeat((np.arange(ns) + 0.5) * H, ny), np.tile((np.arange(ny) + 0.5) * H - sp.gauge_w / 2,
                                                                        ns)], 1)
    gl = (sp.length - sp.gauge_l) / 2
    gauge = (centre[:, 0] > gl) & (centre[:, 0] < sp.length - gl)
    ref = float(np.median(exx[gauge]))
    emax = (exx + eyy) / 2 + np.sqrt(((exx - eyy) / 2) ** 2 + (gxy / 2) ** 2)
    return {"centre": centre, "emax": emax / ref, "exx": exx / ref, "gauge": gauge, "u": u.reshape(ns + 1, ny + 1, 2),
            "reaction": np.array([f[2 * pull].sum(), f[2 * pull + 1].sum()])}


def free_drift(sp: tf.Specimen, angle: str, n_grid: int = 24) -> float:
    """The lateral drift ``beta`` (the pulled grip's displacement along ``n`` over its displacement along ``a``) at
    which the pulled grip carries no transverse force: two solves, the reaction linear in ``beta``. 0 at 0 deg."""
    if float(angle) == 0.0:
        return 0.0
    r0, r1 = (elastic_field(sp, angle, n_grid, b)["reaction"][1] for b in (0.0, 1.0))
    return float(-r0 / (r1 - r0))


def static_velocity(sp: tf.Specimen, angle: str, n_grid: int, beta: float, local: np.ndarray) -> np.ndarray:
    """The quasi-static velocity (m/s, (n, 2) along ``a`` and ``n``) at the points ``local`` (n, 3; the specimen's
    frame, ``s`` from 0) when the pulled grip moves at ``tf.PULL`` along ``a + beta n``: the elastic solution's
    displacement, bilinear between its nodes, scaled from its 1e-3 m pull."""
    from scipy.interpolate import RegularGridInterpolator
    u = elastic_field(sp, angle, n_grid, beta)["u"]
    s = np.linspace(0, sp.length, u.shape[0])
    y = np.linspace(-sp.gauge_w / 2, sp.gauge_w / 2, u.shape[1])
    q = np.stack([np.clip(local[:, 0], 0, sp.length), np.clip(local[:, 1], y[0], y[-1])], 1)
    return np.stack([RegularGridInterpolator((s, y), u[..., k])(q) for k in (0, 1)], 1) * (tf.PULL / 1e-3)


def spread(r: dict) -> list[float]:
    """The gauge's largest principal strain over its median: 5th, 95th percentile, least, largest."""
    e = r["emax"][r["gauge"]]
    return [round(float(v), 3) for v in (*np.percentile(e, [5, 95]), e.min(), e.max())]


def main() -> None:
    rows = []
    for name in ("dogbone_2to1", "dogbone_1.5to1"):
        sp = {s.name: s for s in tf.FAMILY}[name]
        for angle in ("0", "30", "45"):
            beta = free_drift(sp, angle)
            for grip, b in (("along a", 0.0), ("free", beta)):
                r = elastic_field(sp, angle, 24, b)
                rows.append({"specimen": name, "angle": angle, "grip": grip, "beta": round(beta if b else 0.0, 4),
                             "spread": spread(r), "transverse_over_axial": float(r["reaction"][1] / r["reaction"][0])})
                print(json.dumps(rows[-1]), flush=True)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "oblique_grip.json").write_text(json.dumps({"rows": rows}, indent=1))
    out = ["# The oblique dog-bones' elastic gauge under their holds (issue 66, round 40)", "",
           "`python benchmarks/oblique_grip.py`: plane-stress finite elements (side 2.5 mm), the holds of "
           "`tension_oblique.build` at n_grid 24. The gauge's largest principal strain over its median (5th-95th "
           "percentile, least, largest) with the pulled grip moved along the axis (`along a`, the benchmark's "
           "default) and along `a + beta n` (`free`: no transverse force on the grip).", "",
           "| specimen | angle | grip | beta | 5 % | 95 % | least | largest | transverse / axial force |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = r["spread"]
        out.append(f"| {r['specimen']} | {r['angle']} | {r['grip']} | {r['beta']:.3f} | {p[0]:.3f} | {p[1]:.3f} | "
                   f"{p[2]:.3f} | {p[3]:.3f} | {r['transverse_over_axial']:+.4f} |")
    (RESULTS / "oblique_grip.md").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
