"""A run as one OpenUSD file: a ``ParticleField3DGaussianSplat`` prim per object, time-sampled per frame
(``gasp export RUN --format usd``, ``gasp simulate --format usd``), written with usd-core (the ``export`` extra).

Schema: ``UsdVol.ParticleField3DGaussianSplat`` of OpenUSD 26.03+ (usd-core 26.11's
``pxr/pluginfo/usdVol/resources/generatedSchema.usda``): ``positions`` (point3f[], local space),
``orientations`` (quatf[]), ``scales`` (float3[], linear), ``opacities`` (float[]), and
``radiance:sphericalHarmonicsCoefficients`` (float3[]) with ``radiance:sphericalHarmonicsDegree``.

What GASP writes:

* one prim per object, ``/Run/<object>``; the stage's up axis is +Z (``UsdGeom.SetStageUpAxis``), each object's
  file frame turned so that its ``up_axis`` is +Z (the file's units kept, ``metersPerUnit`` 1);
* ``positions``, ``orientations`` and ``scales`` time-sampled at every frame, time code = frame index,
  ``timeCodesPerSecond = framesPerSecond = 1 / frame_dt`` (the run's frame rate), start 0, end the last frame;
  an object that does not move (``static``) is written once, without time samples;
* ``opacities`` (``sigmoid`` of the logit, in [0, 1]) and the SH coefficients once: GASP never changes them
  over a run. The coefficients are written per particle, ``(degree + 1)^2`` of them each, DC first, then the
  graphdeco order of the higher degrees (m = -l .. l), rotated with the object when its up axis is not +Z;
* a ``brittle`` object's crack faces (``gasp export``, unless ``--no-crack-faces``): a sibling prim
  ``/Run/<object>_crack_faces`` with every face of the object, positions, orientations, scales and opacities
  time-sampled (0 while a face is hidden, so the count is one over the run); split by pieces, one per piece
  (``piece_NNN_faces``, :mod:`gasp_core.run.split_pieces`).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from gasp_core.fsutil import atomic_path
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.gltf import UP_TO_Z, turned


def pxr_modules(path):
    """``(Usd, UsdGeom, UsdVol, Vt, Gf)``, or :class:`~gasp_core.errors.GaspError` with the install line."""
    try:
        from pxr import Gf, Usd, UsdGeom, UsdVol, Vt
    except ImportError:
        from gasp_core.errors import GaspError, extra_hint
        raise GaspError(f"{path}: OpenUSD needs usd-core, which is not installed ({extra_hint('export')})") from None
    if not hasattr(UsdVol, "ParticleField3DGaussianSplat"):
        from gasp_core.errors import GaspError
        raise GaspError(f"{path}: the installed usd-core has no UsdVol.ParticleField3DGaussianSplat (OpenUSD 26.03+ "
                        "has it): pip install -U usd-core")
    return Usd, UsdGeom, UsdVol, Vt, Gf


def _sh_coefficients(g: Gaussians) -> np.ndarray:
    """(n * (degree+1)^2, 3) float32: per particle its DC then its rest coefficients."""
    return np.concatenate([g.sh_dc[:, None, :], g.sh_rest], 1).reshape(-1, 3).astype(np.float32)


def write_usd(path, frames, names: list[str], up_axes: list[str], frame_dt: float, moving: list[bool], *,
              overwrite: bool = False, pieces: list | None = None, crack_faces: list | None = None) -> Path:
    """Write a run's frames as one ``.usdc`` / ``.usd`` / ``.usda`` (module notes), atomically.

    Parameters
    ----------
    path : path-like
        The file; its suffix picks USD's encoding (``.usd`` and ``.usdc``: crate binary, ``.usda``: text).
    frames : gasp_core.run.layout.RunFrames
        The run's frames (:func:`gasp_core.run.layout.open_frames`); ``frames.gaussians(f, k)`` is object ``k``
        at frame ``f`` in its file frame.
    names, up_axes : list of str
        Per object (manifest order): the prim name and the file frame's up axis.
    frame_dt : float
        Seconds between frames (the run's ``frame_dt``).
    moving : list of bool
        Per object: false for an object that never moves (written once, no time samples).
    overwrite : bool
        Replace an existing file.
    pieces : list, optional
        Per object, None (one prim) or ``[(part name, rows), ...]``: the object becomes an ``Xform`` with one splat
        prim per part holding those rows (ndarray of int), ``/Run/<object>/<part>`` (``--split-pieces``).
    crack_faces : list, optional
        Per object, None or a function ``frame -> Gaussians or None``: the object's crack faces at that frame
        (:func:`gasp_core.run.crack_output.read_crack_faces`). With ``pieces``, each ``piece_NNN`` gets a sibling
        ``piece_NNN_faces`` holding the faces of that piece at the last frame, time-sampled, hidden (opacity 1e-13)
        while the material around them is whole (:func:`_face_prims`); without, the object gets a sibling
        ``/Run/<object>_crack_faces`` holding every face, time-sampled the same way (:func:`_all_faces_prim`).

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    GaspError
        usd-core missing, or without the schema.
    """
    Usd, UsdGeom, UsdVol, Vt, Gf = pxr_modules(path)
    path = Path(path)
    with atomic_path(path, overwrite=overwrite) as tmp:
        stage = Usd.Stage.CreateNew(str(tmp))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        fps = 1.0 / float(frame_dt)
        stage.SetTimeCodesPerSecond(fps)
        stage.SetFramesPerSecond(fps)
        stage.SetStartTimeCode(0)
        stage.SetEndTimeCode(frames.n_frames - 1)
        stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/Run").GetPrim())
        for k, name in enumerate(names):
            parts = [(f"/Run/{prim_name(name)}", None)]
            if pieces is not None and pieces[k] is not None:   # an Xform holding one prim per part
                UsdGeom.Xform.Define(stage, parts[0][0])
                parts = [(f"{parts[0][0]}/{prim_name(part)}", rows) for part, rows in pieces[k]]
            _splat_prims(stage, parts, frames, k, UP_TO_Z[up_axes[k]], moving[k])
            if crack_faces is None or crack_faces[k] is None:
                continue
            if pieces is not None and pieces[k] is not None:
                if len(parts) > 1:
                    _face_prims(stage, f"/Run/{prim_name(name)}", crack_faces[k], frames.n_frames, UP_TO_Z[up_axes[k]])
            else:
                _all_faces_prim(stage, f"/Run/{prim_name(name)}_crack_faces", crack_faces[k], frames.n_frames,
                                UP_TO_Z[up_axes[k]])
        try:
            stage.GetRootLayer().Save()
        except RuntimeError as e:   # pxr.Tf.ErrorException: a full disk, a folder gone or not writable
            first = re.search(r" : '([^']*)'", str(e))   # Tf's first error: "Error occurred writing file: ..."
            why = first.group(1)[:200] if first else type(e).__name__
            raise OSError(f"OpenUSD could not save {path} ({why}); is the disk full or the folder not "
                          "writable?") from None
        del stage
    return path


def prim_name(name: str) -> str:
    """A valid USD prim name from an object name (letters, digits, ``_``; not starting with a digit)."""
    s = "".join(c if c.isalnum() or c == "_" else "_" for c in name) or "object"
    return s if not s[0].isdigit() else f"_{s}"


def _splat_prims(stage, parts: list, frames, k: int, M: np.ndarray, moving: bool) -> None:
    """One ``ParticleField3DGaussianSplat`` per ``(prim path, rows)`` of ``parts``: object ``k``'s Gaussians (those
    rows, or all when None) turned by ``M``, time-sampled at every frame when ``moving`` (module notes); each frame
    is read once."""
    from pxr import Usd, UsdVol, Vt

    def pick(g, rows):
        return g if rows is None else g.subset(rows)

    g0 = turned(frames.gaussians(0, k), M)
    attrs = []
    for path, rows in parts:
        prim = UsdVol.ParticleField3DGaussianSplat.Define(stage, path)
        p0 = pick(g0, rows)
        prim.CreateOpacitiesAttr(Vt.FloatArray.FromNumpy(
            (1.0 / (1.0 + np.exp(-p0.opacities.astype(np.float64)))).astype(np.float32)))
        prim.CreateRadianceSphericalHarmonicsDegreeAttr(p0.sh_degree)
        prim.CreateRadianceSphericalHarmonicsCoefficientsAttr(Vt.Vec3fArray.FromNumpy(_sh_coefficients(p0)))
        attrs.append((prim.CreatePositionsAttr(), prim.CreateOrientationsAttr(), prim.CreateScalesAttr()))
    for f in (range(frames.n_frames) if moving else [None]):
        g = g0 if f in (0, None) else turned(frames.gaussians(f, k), M)
        time = Usd.TimeCode.Default() if f is None else Usd.TimeCode(f)
        for (_, rows), (pos, ori, sca) in zip(parts, attrs):
            p = pick(g, rows)
            q = p.rotations.astype(np.float32)   # wxyz; Gf.Quatf's numpy layout is (i, j, k, real)
            pos.Set(Vt.Vec3fArray.FromNumpy(p.means.astype(np.float32)), time)
            ori.Set(Vt.QuatfArray.FromNumpy(np.ascontiguousarray(q[:, [1, 2, 3, 0]])), time)
            sca.Set(Vt.Vec3fArray.FromNumpy(p.scales.astype(np.float32)), time)


def _face_prims(stage, parent: str, faces_at, n_frames: int, M: np.ndarray) -> None:
    """``<parent>/piece_NNN_faces``: per piece of the last frame's crack faces (their ``piece``; rows of a piece that
    holds no surface Gaussian, -1, left out), one ``ParticleField3DGaussianSplat`` time-sampled at every frame
    (positions, orientations, scales and opacities: a face is drawn from the frame its crack opens); a frame without
    a crack-face file shows none of them."""
    last = faces_at(n_frames - 1)
    if last is None or "piece" not in last.extra:
        return
    piece = np.asarray(last.extra["piece"])
    groups = [(f"{parent}/{prim_name(f'piece_{k:03d}_faces')}", np.flatnonzero(piece == k))
              for k in np.unique(piece[piece >= 0])]
    _sampled_faces(stage, groups, faces_at, last, n_frames, M)


def _all_faces_prim(stage, path: str, faces_at, n_frames: int, M: np.ndarray) -> None:
    """``path``: every crack face of an object in one ``ParticleField3DGaussianSplat``, time-sampled at every frame
    as :func:`_face_prims` (opacity 0 while a face is hidden: one count over the run); nothing without faces."""
    last = faces_at(n_frames - 1)
    if last is not None:
        _sampled_faces(stage, [(path, np.arange(last.n))], faces_at, last, n_frames, M)


def _sampled_faces(stage, groups: list, faces_at, last, n_frames: int, M: np.ndarray) -> None:
    """One splat prim per ``(path, rows of the faces)`` of ``groups``, its DC colour once and its positions,
    orientations, scales and opacities (``sigmoid`` of the logit) at every frame from ``faces_at(frame)``; a frame
    without a file (or with another count) takes the last frame's faces, hidden."""
    from pxr import Usd, UsdVol, Vt
    prims = []
    for path, rows in groups:
        prim = UsdVol.ParticleField3DGaussianSplat.Define(stage, path)
        prim.CreateRadianceSphericalHarmonicsDegreeAttr(0)
        prim.CreateRadianceSphericalHarmonicsCoefficientsAttr(Vt.Vec3fArray.FromNumpy(
            last.subset(rows).sh_dc.astype(np.float32)))
        prims.append((rows, prim.CreatePositionsAttr(), prim.CreateOrientationsAttr(), prim.CreateScalesAttr(),
                      prim.CreateOpacitiesAttr()))
    last_turned = turned(last, M)   # a frame without a file: the last frame's faces, hidden
    for f in range(n_frames):
        g = faces_at(f)
        g = None if g is None or g.n != last.n else turned(g, M)
        time = Usd.TimeCode(f)
        for rows, pos, ori, sca, opa in prims:
            src = (last_turned if g is None else g).subset(rows)
            alpha = np.zeros(len(rows)) if g is None else 1.0 / (1.0 + np.exp(-src.opacities.astype(np.float64)))
            q = src.rotations.astype(np.float32)
            pos.Set(Vt.Vec3fArray.FromNumpy(src.means.astype(np.float32)), time)
            ori.Set(Vt.QuatfArray.FromNumpy(np.ascontiguousarray(q[:, [1, 2, 3, 0]])), time)
            sca.Set(Vt.Vec3fArray.FromNumpy(src.scales.astype(np.float32)), time)
            opa.Set(Vt.FloatArray.FromNumpy(alpha.astype(np.float32)), time)
