"""The capture's unseen Gaussians: what a break must not show (issue 66, "What a user sees"; ``docs/fracture.md``,
"Round 61: the capture's inside").

A trained 3DGS scene puts Gaussians inside an object as well as on it. Training fits only what its cameras see
(Kerbl et al. 2023, "3D Gaussian Splatting for Real-Time Radiance Field Rendering", ACM TOG 42(4): the loss is the
photometric error of the rendered training views), so a Gaussian that every view sees through the ones in front of
it keeps whatever size and colour the optimisation left it: on the README donut, dark, green, white and magenta
blobs up to a centimetre across, inside the dough. Whole, the object hides them; broken, its pieces show them, as
blurred streaks and blots at every crack (round 60's stills). They are not the object's appearance: the inside of a
real biscuit is what its crack faces (:mod:`gasp_core.maps.crack_faces`) draw.

**The rule.** Each Gaussian's *seen share* is the largest, over :data:`VIEWS` cameras spread evenly around the
object at rest (a Fibonacci sphere of directions, each camera framing the object's 99th-percentile radius at
:data:`RESOLUTION` pixels square), share of its own alpha that reaches the image:
``sum_px alpha T / sum_px alpha`` over its footprint (:func:`gasp_core.gs.splat_numpy.shares`, the 3DGS
compositing). An object whose material tears or breaks (:data:`gasp_core.run.frames.TEARING`) draws a Gaussian whose
seen share stays under :data:`UNSEEN` from every direction with opacity ``sigmoid(HIDDEN)`` (not drawn) from frame 1
on (frame 0 is the input as read), and its crack faces take their colour from the seen Gaussians only. A Gaussian no
camera rasterises (under a pixel's ``1/255`` alpha at every view) is kept: nothing says it is unseen.
Whole, the object looks the same: drawn without them, the README donut's rest renders from six other directions are
within 53.6 dB PSNR of the whole (:func:`rest_psnr`; ``benchmarks/studies/unseen_inside.py``).
"""
from __future__ import annotations

import importlib.util
import weakref

import numpy as np

from gasp_core.gs.camera import Camera
from gasp_core.gs.splat_numpy import Splats, render, shares, splats_from_gaussians

#: Directions the seen share is taken from (a Fibonacci sphere). The count hidden depends on them (the README donut:
#: 5 461 / 4 414 / 3 795 of 45 624 at 16 / 32 / 64), the picture at rest does not (hidden at 32: 53.6 dB and more from
#: six other directions; ``benchmarks/results/unseen_inside.md``); 32 take 3.7 s with numba on 2 cores (load 0.8).
VIEWS = 32
#: Pixels across each view (square).
RESOLUTION = 256
#: A Gaussian under this seen share from every direction is unseen (module notes): it never gives the image more than
#: 1 % of its own alpha.
UNSEEN = 0.01
#: Opacity logit of a hidden Gaussian (``sigmoid(-30)`` = 1e-13, the crack faces' hidden logit).
HIDDEN = -30.0
#: Switch: False draws every Gaussian as the map puts it (the rule before round 61, the catch of the tests).
HIDE_UNSEEN = True

_CACHE: dict[int, tuple[weakref.ref, np.ndarray]] = {}


def view_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (the Fibonacci lattice; none at a pole), shape (n, 3)."""
    k = np.arange(n) + 0.5
    theta = np.arccos(1.0 - 2.0 * k / n)
    phi = np.pi * (1.0 + 5.0 ** 0.5) * k
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)


def ring_cameras(splats: Splats, directions: np.ndarray, resolution: int, fov_deg: float = 30.0,
                 distance: float = 1.05) -> list[Camera]:
    """Cameras looking at the splats' median centre from ``directions`` (m, 3), far enough that the 99th-percentile
    radius fits the field of view ``fov_deg`` times ``1 / distance``; ``resolution`` pixels square."""
    c = np.median(splats.means, axis=0)
    rad = max(float(np.quantile(np.linalg.norm(splats.means - c, axis=1), 0.99)), 1e-6)
    d = distance * rad / np.sin(np.radians(fov_deg / 2.0))
    return [Camera(c + d * u, c, fov_deg, resolution, resolution, near=1e-3 * d) for u in directions]


def seen_share(splats: Splats, views: int = VIEWS, resolution: int = RESOLUTION) -> np.ndarray:
    """Each Gaussian's largest seen share over ``views`` cameras around the splats (module notes).

    Parameters
    ----------
    splats : Splats
        World-frame splats of one object at rest (:func:`gasp_core.gs.splat_numpy.splats_from_gaussians`).
    views, resolution : int
        Directions, and pixels across each view.

    Returns
    -------
    ndarray, shape (splats.n,), float64
        In [0, 1]; NaN for a Gaussian no view rasterises.

    Without numba (the ``render`` extra) the views run in NumPy (about 80 s on the README donut against 3.7 s) under a
    tqdm bar on an interactive stderr.
    """
    from tqdm import tqdm
    cams = ring_cameras(splats, view_directions(views), resolution)
    slow = importlib.util.find_spec("numba") is None   # the NumPy path: about 80 s on the README donut, said on a TTY
    best = np.full(splats.n, np.nan)
    for cam in tqdm(cams, desc="unseen Gaussians (NumPy; numba: pip install -e '.[render]')", unit="view",
                    leave=False, disable=None if slow else True):
        best = np.fmax(best, shares(splats, cam))
    return best


def unseen_rows(o, materials: tuple = ("brittle", "plasticine")) -> np.ndarray | None:
    """The file rows of ``o`` (a :class:`gasp_core.prepare.placed.PreparedObject`) drawn hidden after frame 0: its
    simulated Gaussians whose seen share (:func:`seen_share` over those Gaussians alone at rest, world frame: the
    object's own inside, whatever else of its capture stands around it, as a kitchen around a selected pan) is under
    :data:`UNSEEN`; bool, shape (len(o.gaussians),). None where nothing is hidden: :data:`HIDE_UNSEEN` off, a static
    object, or a material not in ``materials`` (those that tear or break: ``gasp_core.run.frames.TEARING``).
    Computed once per object (cached while it lives)."""
    if not HIDE_UNSEEN or o.spec.static or o.spec.material.name not in materials:
        return None
    hit = _CACHE.get(id(o))
    if hit is not None and hit[0]() is o:
        return hit[1]
    pl = o.placement
    rows = np.arange(len(o.gaussians.means)) if o.moving is None else np.asarray(o.moving)
    share = seen_share(splats_from_gaussians(o.gaussians.subset(rows), pl.R, float(pl.scale), pl.t))
    mask = np.zeros(len(o.gaussians.means), bool)
    mask[rows] = share < UNSEEN           # NaN compares False: a Gaussian no view rasterises is kept
    for key in [k for k, (ref, _) in _CACHE.items() if ref() is None]:   # objects gone: their entries too
        del _CACHE[key]
    try:
        _CACHE[id(o)] = (weakref.ref(o), mask)
    except TypeError:                     # an object without weak references is not cached
        pass
    return mask


def hide(g, rows: np.ndarray | None):
    """``g`` (:class:`gasp_core.gs.gaussians.Gaussians`) with the opacity logit of ``rows`` (bool over its rows, or
    None: ``g`` itself) set to :data:`HIDDEN`; a copy, the input's arrays untouched."""
    if rows is None or not rows.any():
        return g
    from dataclasses import replace
    op = np.array(g.opacities, copy=True)
    op[rows] = HIDDEN
    return replace(g, opacities=op)


def rest_psnr(splats: Splats, keep: np.ndarray, n: int = 6, resolution: int = 320, seed: int = 7) -> np.ndarray:
    """PSNR (dB) of the object at rest drawn with only ``keep`` (bool over the splats) against all of it, on a white
    background, from ``n`` random directions (not :func:`view_directions`' own) at 2.2 times its radius; shape (n,)."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    part = splats.subset(keep)
    out = []
    for cam in ring_cameras(splats, u, resolution, fov_deg=40.0, distance=1.4):
        a = np.clip(render(splats, cam, np.ones(3))[0], 0, 1)
        b = np.clip(render(part, cam, np.ones(3))[0], 0, 1)
        out.append(10.0 * np.log10(1.0 / max(float(np.mean((a - b) ** 2)), 1e-12)))
    return np.array(out)
