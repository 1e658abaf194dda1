"""CPU Gaussian splatting in vectorised NumPy: EWA projection and front-to-back alpha blending.

The maths follows 3D Gaussian Splatting (Kerbl et al. 2023, Sec. 4 and the reference CUDA rasteriser):
the 3D covariance ``Sigma = M M^T`` with ``M = R diag(s)`` is projected with the Jacobian of the
perspective map at the Gaussian's centre (EWA splatting, Zwicker et al. 2002), ``Sigma' = J W Sigma
W^T J^T``, plus ``dilation`` px^2 on the diagonal (3DGS's 0.3 low-pass filter). A pixel at offset
``d`` from the projected centre gets ``alpha = min(0.99, opacity * exp(-d^T Sigma'^-1 d / 2))``;
pairs with ``alpha < 1/255`` or outside the 3-sigma ellipse are dropped, and the pixel colour is
``sum_i c_i alpha_i prod_{j<i} (1 - alpha_j)`` over Gaussians sorted near to far, plus the remaining
transmittance times the background.

Implementation: every (Gaussian, pixel) pair inside the Gaussian's footprint is generated, in
chunks of Gaussians taken near to far; inside a chunk pairs are grouped by pixel with a stable sort
(pairs were generated in depth order, so each pixel's run stays depth-sorted), and the per-pixel
exclusive cumulative sum of ``log(1 - alpha)`` gives each pair's transmittance. The transmittance left
after earlier chunks multiplies in, so chunking is exact.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gasp_core.gs.camera import Camera

SH_C0 = 0.28209479177387814
ALPHA_MIN = 1.0 / 255.0
ALPHA_MAX = 0.99


@dataclass
class Splats:
    """Gaussians ready to render, world frame.

    Attributes
    ----------
    means : ndarray, shape (n, 3), float64
        Centres, metres.
    covs : ndarray, shape (n, 3, 3), float64
        3D covariances, m^2.
    rgb : ndarray, shape (n, 3), float32
        Colours in [0, 1]: SH degree 0, or the view-dependent colour once :meth:`seen_from` has run.
    opacities : ndarray, shape (n,), float32
        Activated opacities in [0, 1].
    sh : ndarray, shape (n, (degree + 1) ** 2, 3), float32, optional
        SH coefficients (DC first) when the file has degree 1 to 3; ``None`` for degree 0.
    sh_frames : ndarray, shape (n, 3, 3), optional
        Rotation of a world direction into the frame the SH were fitted in (placement and each
        Gaussian's turn since frame 0, :mod:`gasp_core.gs.sh`); identity when ``None``.
    """

    means: np.ndarray
    covs: np.ndarray
    rgb: np.ndarray
    opacities: np.ndarray
    sh: np.ndarray | None = None
    sh_frames: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.means)

    def subset(self, keep) -> "Splats":
        """The splats at ``keep`` (a bool mask or row indices), every field alike."""
        return Splats(self.means[keep], self.covs[keep], self.rgb[keep], self.opacities[keep],
                      None if self.sh is None else self.sh[keep],
                      None if self.sh_frames is None else self.sh_frames[keep])

    @staticmethod
    def concat(parts: list["Splats"]) -> "Splats":
        """All Gaussians of ``parts`` in one record (SH padded with zeros to the highest degree)."""
        out = Splats(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("means", "covs", "rgb", "opacities")))
        if any(p.sh is not None for p in parts):
            k = max(p.sh.shape[1] for p in parts if p.sh is not None)
            sh, frames = [], []
            for p in parts:
                block = np.zeros((p.n, k, 3), np.float32)
                if p.sh is None:
                    block[:, 0] = (p.rgb - 0.5) / SH_C0
                else:
                    block[:, :p.sh.shape[1]] = p.sh
                sh.append(block)
                frames.append(np.broadcast_to(np.eye(3), (p.n, 3, 3)) if p.sh_frames is None else p.sh_frames)
            out.sh, out.sh_frames = np.concatenate(sh), np.concatenate(frames)
        return out

    def seen_from(self, eye) -> "Splats":
        """These splats with ``rgb`` the colour seen from camera centre ``eye`` (world metres).

        Degree 0 (``sh is None``): ``self`` unchanged. Otherwise the 3DGS SH colour along each
        Gaussian's view direction in its SH frame, clipped to [0, 1].
        """
        if self.sh is None:
            return self
        from gasp_core.gs.sh import sh_colours, view_dirs
        rgb = np.clip(sh_colours(self.sh, view_dirs(self.means, eye, self.sh_frames)), 0.0, 1.0)
        return Splats(self.means, self.covs, rgb, self.opacities)


def splats_from_gaussians(g, R=None, scale: float = 1.0, t=None, rest_rotmats=None) -> Splats:
    """World-frame splats from :class:`~gasp_core.gs.gaussians.Gaussians` placed by ``x = scale R x_file + t``.

    Parameters
    ----------
    g : Gaussians
        File frame; ``scales`` activated, ``opacities`` logits, ``sh_dc`` / ``sh_rest`` SH.
    R : ndarray, shape (3, 3), optional
        Rotation file -> world (identity by default).
    scale : float
        Metres per file unit.
    t : ndarray, shape (3,), optional
        Translation, metres.
    rest_rotmats : ndarray, shape (n, 3, 3), optional
        The Gaussians' rotations (file frame) when the SH were fitted, i.e. at frame 0 of a run;
        with SH degree >= 1 the view direction is turned by ``rest_rotmats @ g.rotmats()^T``
        (default: no turn).

    Returns
    -------
    Splats
        Colour ``clip(0.5 + 0.28209479 * sh_dc, 0, 1)`` (3DGS's degree-0 colour), opacity
        ``sigmoid(opacities)``; ``sh`` and ``sh_frames`` when the file has SH degree 1 to 3.
    """
    R = np.eye(3) if R is None else np.asarray(R, dtype=np.float64)
    t = np.zeros(3) if t is None else np.asarray(t, dtype=np.float64)
    rot = g.rotmats()
    M = np.einsum("ij,njk->nik", R, rot) * (scale * g.scales)[:, None, :]
    covs = M @ M.transpose(0, 2, 1)
    means = scale * g.means @ R.T + t
    rgb = np.clip(0.5 + SH_C0 * g.sh_dc.astype(np.float32), 0.0, 1.0)
    with np.errstate(over="ignore"):        # a logit below -709 is opacity 0, not a warning
        opac = (1.0 / (1.0 + np.exp(-g.opacities.astype(np.float64)))).astype(np.float32)
    out = Splats(means, covs, rgb, opac)
    if g.sh_rest.shape[1]:
        out.sh = np.concatenate([g.sh_dc[:, None, :], g.sh_rest], axis=1).astype(np.float32)
        turn = R.T if rest_rotmats is None else np.einsum("nij,nkj->nik", rest_rotmats, rot) @ R.T
        out.sh_frames = np.broadcast_to(turn, (g.n, 3, 3)) if turn.ndim == 2 else turn
    return out


def project(splats: Splats, cam: Camera, dilation: float = 0.3):
    """Project splats to the image: centres, inverse 2D covariances (conics) and pixel footprints.

    Returns
    -------
    dict of ndarray
        For the Gaussians in front of the camera whose footprint meets the image, sorted near to far:
        ``idx`` (rows of ``splats``), ``depth``, ``u, v`` (pixel coordinates, pixel ``i`` spans
        ``[i, i+1)``), ``conic`` (n, 3) = (A, B, C) of ``Sigma'^-1``, ``x0, x1, y0, y1`` (int32,
        half-open pixel boxes), ``opacity``, ``rgb``.
    """
    W, t = cam.world_to_camera()
    pc = splats.means @ W.T + t
    z = pc[:, 2]
    front = z > cam.near
    idx = np.flatnonzero(front)
    pc, z = pc[idx], z[idx]
    fx = fy = cam.focal_px
    # 3DGS clamps the Jacobian's x/z, y/z to 1.3x the half field of view (stable for off-screen centres)
    lim_x = 1.3 * (0.5 * cam.width / fx)
    lim_y = 1.3 * (0.5 * cam.height / fy)
    tx = np.clip(pc[:, 0] / z, -lim_x, lim_x) * z
    ty = np.clip(pc[:, 1] / z, -lim_y, lim_y) * z
    J = np.zeros((len(idx), 2, 3))
    J[:, 0, 0] = fx / z
    J[:, 0, 2] = -fx * tx / z**2
    J[:, 1, 1] = fy / z
    J[:, 1, 2] = -fy * ty / z**2
    T = J @ W
    S = T @ splats.covs[idx] @ T.transpose(0, 2, 1)
    a = S[:, 0, 0] + dilation
    b = S[:, 0, 1]
    c = S[:, 1, 1] + dilation
    det = a * c - b * b
    ok = det > 1e-12
    u = fx * pc[:, 0] / z + cam.cx
    v = fy * pc[:, 1] / z + cam.cy
    op = splats.opacities[idx].astype(np.float64)
    # footprint: the 3-sigma ellipse, shrunk to where opacity * exp(-m^2/2) >= 1/255
    m2 = np.minimum(9.0, 2.0 * np.log(np.maximum(op, 1e-12) / ALPHA_MIN))
    ok &= m2 > 0
    rx = np.sqrt(np.maximum(m2 * a, 0.0))
    ry = np.sqrt(np.maximum(m2 * c, 0.0))
    x0 = np.floor(u - rx).clip(0, cam.width).astype(np.int32)
    x1 = np.ceil(u + rx).clip(0, cam.width).astype(np.int32)
    y0 = np.floor(v - ry).clip(0, cam.height).astype(np.int32)
    y1 = np.ceil(v + ry).clip(0, cam.height).astype(np.int32)
    ok &= (x1 > x0) & (y1 > y0)
    sel = np.flatnonzero(ok)
    sel = sel[np.argsort(z[sel], kind="stable")]
    det = det[sel]
    conic = np.stack([c[sel] / det, -b[sel] / det, a[sel] / det], axis=1)
    return {"idx": idx[sel], "depth": z[sel], "u": u[sel], "v": v[sel], "conic": conic,
            "m2": m2[sel], "x0": x0[sel], "x1": x1[sel], "y0": y0[sel], "y1": y1[sel],
            "opacity": op[sel], "rgb": splats.rgb[idx[sel]].astype(np.float64)}


def _stable_group(pix: np.ndarray) -> np.ndarray:
    """Stable permutation grouping equal pixel indices (two 16-bit radix passes)."""
    lo = (pix & 0xFFFF).astype(np.uint16)
    hi = (pix >> 16).astype(np.uint16)
    o1 = np.argsort(lo, kind="stable")
    o2 = np.argsort(hi[o1], kind="stable")
    return o1[o2]


def render(splats: Splats, cam: Camera, background=None, *, dilation: float = 0.3,
           chunk_pairs: int = 4_000_000):
    """Render splats seen by ``cam`` (vectorised NumPy, CPU).

    Parameters
    ----------
    splats : Splats
    cam : Camera
    background : ndarray, shape (height, width, 3) or (3,), optional
        Colour behind the Gaussians (black by default).
    dilation : float
        Added to the 2D covariance's diagonal, px^2 (3DGS uses 0.3).
    chunk_pairs : int
        Approximate number of (Gaussian, pixel) pairs handled at once (memory bound).

    Returns
    -------
    image : ndarray, shape (height, width, 3), float32
        Linear colour, not clipped.
    alpha : ndarray, shape (height, width), float32
        Accumulated opacity ``1 - T``.
    """
    H, Wd = cam.height, cam.width
    colour, logT = _composite_all(project(splats, cam, dilation), cam, chunk_pairs)
    T = np.exp(logT)
    img = colour.T.reshape(H, Wd, 3)
    if background is not None:
        bg = np.broadcast_to(np.asarray(background, dtype=np.float64), (H, Wd, 3))
        img = img + T.reshape(H, Wd, 1) * bg
    return img.astype(np.float32), (1.0 - T).reshape(H, Wd).astype(np.float32)


def _composite_all(p, cam: Camera, chunk_pairs: int, seen=None) -> tuple[np.ndarray, np.ndarray]:
    """Composite the projected splats ``p`` near to far in chunks of about ``chunk_pairs`` (Gaussian, pixel) pairs:
    the colour (3, npix) and log transmittance (npix,); ``seen`` (two arrays over ``p``'s rows) gathers each
    Gaussian's weight and alpha (:func:`shares`)."""
    bw = (p["x1"] - p["x0"]).astype(np.int64)
    counts = bw * (p["y1"] - p["y0"]).astype(np.int64)
    ends = np.cumsum(counts)
    colour, logT = np.zeros((3, cam.height * cam.width)), np.zeros(cam.height * cam.width)
    g0 = 0
    while g0 < len(counts):
        base = ends[g0 - 1] if g0 else 0
        g1 = max(int(np.searchsorted(ends, base + chunk_pairs, side="right")), g0 + 1)
        _composite_chunk(p, g0, g1, counts, bw, cam.width, colour, logT, seen)
        g0 = g1
    return colour, logT


def _composite_chunk(p, g0, g1, counts, bw, width, colour, logT, seen=None):
    cnt = counts[g0:g1]
    total = int(cnt.sum())
    if total == 0:
        return
    g = np.repeat(np.arange(g0, g1), cnt)
    starts = np.cumsum(cnt) - cnt
    k = np.arange(total) - np.repeat(starts, cnt)
    w = bw[g]
    py, px = np.divmod(k, w)
    px += p["x0"][g]
    py += p["y0"][g]
    dx = px + 0.5 - p["u"][g]
    dy = py + 0.5 - p["v"][g]
    con = p["conic"][g]
    m = con[:, 0] * dx * dx + 2.0 * con[:, 1] * dx * dy + con[:, 2] * dy * dy
    alpha = np.minimum(ALPHA_MAX, p["opacity"][g] * np.exp(-0.5 * m))
    keep = (m <= p["m2"][g]) & (alpha >= ALPHA_MIN)
    g, alpha = g[keep], alpha[keep]
    pix = (py[keep] * width + px[keep]).astype(np.int64)
    order = _stable_group(pix)
    pix, alpha, g = pix[order], alpha[order], g[order]
    la = np.log1p(-alpha)
    cs = np.cumsum(la)
    first = np.empty(len(pix), dtype=bool)
    first[0] = True
    np.not_equal(pix[1:], pix[:-1], out=first[1:])
    seg = np.cumsum(first) - 1
    seg_base = (cs - la)[first]                      # cumulative sum before each pixel's first pair
    excl = cs - la - seg_base[seg]                   # sum of log(1 - alpha) of nearer pairs, this chunk
    wgt = alpha * np.exp(excl + logT[pix])
    if seen is not None:   # per Gaussian (rows of p): what reached the image, and its own alpha (:func:`shares`)
        np.add(seen[0], np.bincount(g, weights=wgt, minlength=len(seen[0])), out=seen[0])
        np.add(seen[1], np.bincount(g, weights=alpha, minlength=len(seen[1])), out=seen[1])
    rgb = p["rgb"][g]
    npix = colour.shape[1]
    for ch in range(3):
        colour[ch] += np.bincount(pix, weights=wgt * rgb[:, ch], minlength=npix)
    logT += np.bincount(pix, weights=la, minlength=npix)


def shares(splats: Splats, cam: Camera, dilation: float = 0.3, chunk_pairs: int = 4_000_000) -> np.ndarray:
    """Per Gaussian, the share of its own alpha that reaches the image seen by ``cam``: ``sum_px alpha T / sum_px
    alpha`` over its footprint's pixels (``T`` the transmittance of the Gaussians in front, the compositing of
    :func:`render`); NaN for a Gaussian with no pixel (behind the camera, off the image, or under ``ALPHA_MIN``).

    Returns
    -------
    ndarray, shape (splats.n,), float64, in [0, 1] or NaN
    """
    p = project(splats, cam, dilation)
    try:   # the numba kernel (the render extra), else the NumPy chunks: the same sums
        seen = composite_ordered(p, cam.width, cam.height, 0.0, gather=True)[2]
    except ImportError:
        seen = (np.zeros(len(p["idx"])), np.zeros(len(p["idx"])))
        _composite_all(p, cam, chunk_pairs, seen)
    out = np.full(splats.n, np.nan)
    hit = seen[1] > 0
    out[p["idx"][hit]] = seen[0][hit] / seen[1][hit]
    return out


def composite_ordered(p, width: int, height: int, t_min: float = 1e-4, gather: bool = False):
    """Front-to-back blending of projected splats ``p`` (from :func:`project`) with the JIT kernel.

    Same maths as :func:`render`'s NumPy path; a pixel stops taking Gaussians once its
    transmittance falls below ``t_min`` (as the 3DGS rasteriser does).

    Returns
    -------
    colour : ndarray, shape (height * width, 3), float64
    T : ndarray, shape (height * width,), float64
        Transmittance left.
    seen : tuple of two ndarray, shape (len(p["idx"]),), or None
        With ``gather``: each Gaussian's ``sum alpha T`` and ``sum alpha`` over its pixels (:func:`shares`).

    Raises
    ------
    ImportError
        If numba is not installed (``pip install -e ".[render]"``).
    """
    from gasp_core.gs._splat_numba import composite
    colour = np.zeros((height * width, 3))
    T = np.ones(height * width)
    shape = ((height + 15) // 16, len(p["idx"])) if gather else (1, 1)
    num, den = np.zeros(shape), np.zeros(shape)
    composite(p["u"], p["v"], np.ascontiguousarray(p["conic"]), p["m2"], p["opacity"],
              np.ascontiguousarray(p["rgb"]), p["x0"], p["x1"], p["y0"], p["y1"], width, height,
              colour, T, t_min, num, den, gather)
    return colour, T, ((num.sum(axis=0), den.sum(axis=0)) if gather else None)
