"""How far the GaMeS rebuild ``T^-1`` (Gram-Schmidt, gasp_core/maps/games.py) is from PhysGaussian's
``Sigma' = F Sigma F^T`` under one affine deformation ``F``; writes benchmarks/results/rebuild.md.

For each of N random flat Gaussians (random orientation, in-plane scales s2, s3 in [0.5, 1.5] cm):
map to the triangle (``T``), move its vertices by ``x -> F x``, rebuild (``T^-1``), and compare the
covariance ``R diag(eps^2, s2^2, s3^2) R^T`` with ``F Sigma_0 F^T``. Figures per deformation:

- ``cov``: ``||Sigma_games - F Sigma F^T||_F / ||F Sigma F^T||_F`` (median, 95th percentile, max);
- ``axes``: largest relative error of the in-plane standard deviations (sqrt of the two largest
  eigenvalues), median and max;
- ``normal``: largest angle between the rebuilt normal r1 and the normal of ``F Sigma F^T``
  (its null direction), degrees;
- ``area``: largest relative error of the in-plane ellipse area ``s2 s3`` vs ``sqrt`` of the product
  of the two largest eigenvalues of ``F Sigma F^T``.

Run: ``python benchmarks/bench_rebuild.py [N]`` (default 20000, a second or two).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from gasp_core.maps.games import EPS, gaussians_to_triangles, triangles_to_gaussians


def random_rotations(n: int, rng) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], axis=1)


def cov(rot: np.ndarray, scales: np.ndarray) -> np.ndarray:
    return np.einsum("nij,nj,nkj->nik", rot, scales ** 2, rot)


def compare(F: np.ndarray, n: int = 20000, seed: int = 0) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    rot = random_rotations(n, rng)
    scales = np.stack([np.full(n, EPS), rng.uniform(0.005, 0.015, n), rng.uniform(0.005, 0.015, n)], axis=1)
    means = rng.uniform(-0.5, 0.5, size=(n, 3))
    tri = gaussians_to_triangles(means, rot, scales) @ F.T
    _, rot_g, s_g, _ = triangles_to_gaussians(tri)
    ref = F @ cov(rot, scales) @ F.T
    got = cov(rot_g, s_g)
    err = np.linalg.norm(got - ref, axis=(1, 2)) / np.linalg.norm(ref, axis=(1, 2))
    ev_r, vec_r = np.linalg.eigh(ref)
    ev_g = np.linalg.eigvalsh(got)
    sd_r, sd_g = np.sqrt(np.maximum(ev_r[:, 1:], 0)), np.sqrt(np.maximum(ev_g[:, 1:], 0))
    axes = np.abs(sd_g / sd_r - 1).max(axis=1)
    normal_ref = vec_r[:, :, 0]
    ang = np.degrees(np.arccos(np.clip(np.abs(np.sum(normal_ref * rot_g[:, :, 0], axis=1)), 0, 1)))
    area = np.abs(s_g[:, 1] * s_g[:, 2] / np.prod(sd_r, axis=1) - 1)
    return {"cov_median": float(np.median(err)), "cov_p95": float(np.percentile(err, 95)),
            "cov_max": float(err.max()), "axes_median": float(np.median(axes)), "axes_max": float(axes.max()),
            "normal_max_deg": float(ang.max()), "area_max": float(area.max())}


def deformations() -> dict[str, np.ndarray]:
    c, s = math.cos(0.7), math.sin(0.7)
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    shear = np.eye(3)
    shear[0, 1] = 1.0
    return {"rotation 0.7 rad about z": rz,
            "uniform stretch x1.5": 1.5 * np.eye(3),
            "uniaxial stretch x1.5 (x)": np.diag([1.5, 1.0, 1.0]),
            "uniaxial compression x0.67 (x)": np.diag([1 / 1.5, 1.0, 1.0]),
            "simple shear gamma 0.5 (xy)": np.eye(3) + 0.5 * (shear - np.eye(3)),
            "simple shear gamma 1.0 (xy)": shear}


def main(n: int = 20000) -> str:
    rows = ["| deformation F | cov median | cov p95 | cov max | axes median | axes max | normal max (deg) | area max |",
            "|---|---|---|---|---|---|---|---|"]
    for name, F in deformations().items():
        r = compare(F, n)
        rows.append(f"| {name} | {r['cov_median']:.1%} | {r['cov_p95']:.1%} | {r['cov_max']:.1%} | "
                    f"{r['axes_median']:.1%} | {r['axes_max']:.1%} | {r['normal_max_deg']:.2g} | {r['area_max']:.1e} |")
    text = (f"# GaMeS rebuild T^-1 vs F Sigma F^T ({n} random flat Gaussians, benchmarks/bench_rebuild.py)\n\n"
            + "\n".join(rows) + "\n")
    out = Path(__file__).parent / "results" / "rebuild.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return text


if __name__ == "__main__":
    print(main(int(sys.argv[1]) if len(sys.argv) > 1 else 20000))
