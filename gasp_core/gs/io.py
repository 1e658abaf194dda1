"""Reading and writing Gaussian Splatting files.

Layouts read by :func:`read_gaussians` (a PLY's from its header, never from the file name):

``"3dgs"``
    graphdeco-inria/gaussian-splatting ``scene/gaussian_model.py: save_ply``: vertex properties
    ``x y z [nx ny nz] f_dc_0..2 f_rest_0..(3K-1) opacity scale_0..2 rot_0..3`` (float32).
    ``scale_*`` are natural-log scales, ``opacity`` a logit, ``rot_*`` an **unnormalised** w,x,y,z
    quaternion, ``f_rest_*`` **channel-major** (all K red coefficients, then green, then blue).
``"games"``
    The same layout with every ``scale_0 = log(1e-8)``: flat GaMeS Gaussians, thin axis =
    rotation column 0.
``"2dgs"``
    2D Gaussian Splatting: only ``scale_0, scale_1``; the surfel normal is rotation column 2. It
    is converted on read to the GaMeS convention (see :func:`read_gaussians`).
``"compressed"``
    The PlayCanvas / SuperSplat compressed PLY (element ``chunk`` + 4 packed uint32 per splat).
``"splatv"``
    antimatter15's splaTV dynamic format (:mod:`gasp_core.gs.splatv`).
``"spz"``, ``"sog"``, ``"splat"``, ``"ksplat"``, ``"glb"``
    Files that are not PLY: :mod:`gasp_core.gs.formats`, :mod:`gasp_core.gs.gltf`.

:func:`read_gaussians` reads any of them through the format registry (:mod:`gasp_core.gs.registry`, which tells
the format from the file's first bytes, or its suffix where the format has no signature);
:func:`read_ply_gaussians` is the registry's PLY reader.

Every reader returns a :class:`~gasp_core.gs.gaussians.Gaussians`; rotations are normalised on read
(the stored quaternion norms are not kept, so a write-back stores unit quaternions). Opacities,
SH coefficients and extra properties keep the float32 values of the file, so that
``read(write(read(f)))`` reproduces them bit for bit.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from plyfile import PlyData, PlyElement

from gasp_core.fsutil import atomic_write
from gasp_core.gs.gaussians import Gaussians, MAX_MAGNITUDE, quat_to_rotmat, rotmat_to_quat, SH_REST_COUNT
from gasp_core.maps.games import EPS as FLAT_EPS

from gasp_core.gs.compressed import decode_compressed
from gasp_core.gs.ply import MAX_AT_ONE_POINT, refuse_one_point_means  # noqa: F401 (MAX_AT_ONE_POINT: re-exported)
from gasp_core.gs.ply import (check_columns, column, numbered_names, read_ply, reject_file, require_columns,
                              stack_columns)

#: Column permutation from a 2DGS rotation (t_u, t_v, n) to the GaMeS convention (n, t_u, t_v):
#: column j of the stored-in-memory R is column ``_2DGS_PERM[j]`` of the file's rotation. It is a
#: cyclic permutation, so ``det`` stays +1.
_2DGS_PERM = (2, 0, 1)

__all__ = ["read_gaussians", "read_ply_gaussians", "write_gaussians"]


def refuse_one_point(path, g: Gaussians) -> None:
    """Refuse a file of more than :data:`~gasp_core.gs.ply.MAX_AT_ONE_POINT` Gaussians whose centres are all equal,
    before any work that grows with their count (O(n) time, no copy): :func:`gasp_core.gs.ply.refuse_one_point_means`
    (the readers of large formats check their files before this: :func:`gasp_core.gs.ply.refuse_one_point_file`).

    Raises
    ------
    SceneError
        One line naming the file, the count and the point.
    """
    refuse_one_point_means(path, g.means)


def read_gaussians(path) -> Gaussians:
    """Read any splat file the format registry reads (:func:`gasp_core.gs.registry.read`): a PLY (below), ``.spz``,
    ``.sog``, ``.splat``, ``.ksplat``, ``.glb`` (``KHR_gaussian_splatting``) or ``.splatv`` (at model time 0.5).

    Raises
    ------
    FileNotFoundError, SceneError, GaspError
        As :func:`gasp_core.gs.registry.read`.
    """
    from gasp_core.gs.registry import read
    return read(path)


def read_ply_gaussians(path, fmt: str | None = None) -> Gaussians:
    """Read a Gaussian Splatting PLY (graphdeco 3DGS, GaMeS, 2DGS or PlayCanvas compressed); the registry's reader
    of ``ply`` and ``compressed_ply`` (``fmt`` is not used: the header decides).

    Parameters
    ----------
    path : str or os.PathLike
        A binary or ASCII PLY file.

    Returns
    -------
    Gaussians
        ``layout`` says which layout was detected; ``source`` is ``str(path)``. Means and
        activated scales are float64 in file units; rotations unit wxyz quaternions (normalised
        here, stored norms dropped); opacities, ``sh_dc``, ``sh_rest`` and extra properties keep
        the file's values (float32 for the standard fields, verbatim dtype for extras).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SceneError
        One line naming the file and the problem: a truncated or corrupt PLY, no ``vertex``
        element, no ``x y z``, no ``scale_*`` (neither 3 nor 2 of them), a missing ``rot_*``,
        ``f_dc_*`` or ``opacity``, an ``f_rest_*`` count that is not 0, 9, 24 or 45, a
        non-finite position or rotation, a zero quaternion, or a compressed PLY whose chunk
        count does not match.

    Notes
    -----
    * ``f_rest`` (N, 3K) is channel-major (graphdeco ``save_ply`` flattens ``features_rest`` of
      shape (N, 3, K)), so ``sh_rest[i, k, c] = f_rest_{c*K + k}``.
    * GaMeS: detected when every ``scale_0 <= log(1e-8) + 0.01``; ``layout = "games"``.
    * 2DGS (hbb1/2d-gaussian-splatting, ``scene/gaussian_model.py``: two scales, normal = rotation
      column 2) is converted to the GaMeS convention, thin axis = column 0: the rotation columns
      ``(r1, r2, r3)`` become ``(r3, r1, r2)`` (a cyclic permutation, still a proper rotation)
      and the scales ``(s1, s2)`` become ``(1e-8, s1, s2)``. ``meta["rotation_columns_from_file"]
      = (2, 0, 1)`` records it; ``write_gaussians(..., layout="2dgs")`` undoes it.
    * Compressed PLY: see :func:`gasp_core.gs.compressed.decode_compressed`.
    """
    path = Path(path)
    ply = read_ply(path)
    names_el = [e.name for e in ply.elements]
    if "vertex" not in names_el:
        reject_file(path, f"no 'vertex' element (elements: {names_el}); expected a Gaussian Splatting PLY")
    vertex = ply["vertex"].data
    names = list(vertex.dtype.names or ())
    if "chunk" in names_el or any(n.startswith("packed_") for n in names):
        return decode_compressed(path, ply)
    layout, scale_names, rest_names = _vertex_layout(path, names, ply)
    k = len(rest_names) // 3
    n = len(vertex)
    means, q = _checked_values(path, vertex, scale_names, rest_names)
    log_s = stack_columns(vertex, scale_names)
    opacities = np.array(column(vertex, "opacity"), dtype=np.float32)
    sh_dc = stack_columns(vertex, ("f_dc_0", "f_dc_1", "f_dc_2"), dtype=np.float32)
    if k:
        f_rest = stack_columns(vertex, rest_names, dtype=np.float32)
        sh_rest = np.ascontiguousarray(f_rest.reshape(n, 3, k).transpose(0, 2, 1))
    else:
        sh_rest = np.zeros((n, 0, 3), dtype=np.float32)
    known = {"x", "y", "z", "opacity", *scale_names, *rest_names,
             "rot_0", "rot_1", "rot_2", "rot_3", "f_dc_0", "f_dc_1", "f_dc_2"}
    extra = {nm: np.array(column(vertex, nm)) for nm in names if nm not in known}
    meta: dict[str, Any] = {}
    with np.errstate(over="ignore"):
        if layout == "2dgs":
            R = quat_to_rotmat(q)[:, :, list(_2DGS_PERM)]
            q = rotmat_to_quat(R)
            scales = np.concatenate([np.full((n, 1), FLAT_EPS), np.exp(log_s)], axis=1)
            meta["rotation_columns_from_file"] = _2DGS_PERM
        else:
            if n and np.all(log_s[:, 0] <= math.log(FLAT_EPS) + 0.01):
                layout = "games"
            scales = np.exp(log_s)
    return Gaussians(means=means, scales=scales, rotations=q, opacities=opacities, sh_dc=sh_dc,
                     sh_rest=sh_rest, extra=extra, source=str(path), layout=layout, meta=meta)


def _vertex_layout(path: Path, names: list[str], ply) -> tuple[str, list[str], list[str]]:
    """The layout of an uncompressed vertex element from its property names: ``"3dgs"`` (three scales) or
    ``"2dgs"`` (two), its ``scale_*`` and ``f_rest_*`` names. Refuses (:class:`SceneError`) a triangle mesh
    (faces, no scales), a missing position, rotation, colour or opacity, or an ``f_rest_*`` count other than
    0, 9, 24 or 45."""
    require_columns(path, names, ("x", "y", "z"), "positions x, y, z")
    scale_names = numbered_names(names, "scale_")
    if not scale_names and "face" in [e.name for e in ply.elements]:
        reject_file(path, f"a triangle mesh ({ply['vertex'].count} vertices, {ply['face'].count} faces), not "
                    "Gaussians: give it as an object's 'mesh' (GaMeS mesh mode, docs/mesh_mode.md)")
    if scale_names == ["scale_0", "scale_1", "scale_2"]:
        layout = "3dgs"
    elif scale_names == ["scale_0", "scale_1"]:
        layout = "2dgs"
    else:
        reject_file(path, f"unknown layout: scale properties {scale_names or 'none'}; expected "
                    "scale_0..scale_2 (3DGS, GaMeS) or scale_0, scale_1 (2DGS)")
    require_columns(path, names, ("rot_0", "rot_1", "rot_2", "rot_3"), "a quaternion rot_0..rot_3 (w,x,y,z)")
    require_columns(path, names, ("f_dc_0", "f_dc_1", "f_dc_2"), "SH DC colour f_dc_0..f_dc_2")
    require_columns(path, names, ("opacity",), "an opacity logit")
    rest_names = numbered_names(names, "f_rest_")
    if len(rest_names) % 3 or len(rest_names) // 3 not in SH_REST_COUNT.values() \
            or rest_names != [f"f_rest_{i}" for i in range(len(rest_names))]:
        reject_file(path, f"unknown layout: {len(rest_names)} f_rest_* properties; expected 0, 9, 24 "
                    "or 45 numbered from f_rest_0 (SH degree 0..3)")
    return layout, scale_names, rest_names


def _checked_values(path: Path, vertex: np.ndarray, scale_names: list[str],
                    rest_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Means (n, 3) float64 and unit quaternions (n, 4) wxyz of a vertex element, after refusing
    (:class:`SceneError`) a non-finite or too distant position, a log-scale above ``log(MAX_MAGNITUDE)``,
    a non-finite colour or normal (``nx ny nz``), a NaN opacity (+-inf are alpha 1 and 0), and a zero or
    non-finite quaternion."""
    means = stack_columns(vertex, ("x", "y", "z"))
    bad = ~np.isfinite(means).all(axis=1)
    if bad.any():
        reject_file(path, f"non-finite position (x, y, z) at vertex {int(np.flatnonzero(bad)[0])}")
    check_columns(path, vertex, ("x", "y", "z"), lo=-MAX_MAGNITUDE, hi=MAX_MAGNITUDE)
    # log scales: exp must stay <= MAX_MAGNITUDE; -inf is a zero scale (write_gaussians writes those)
    check_columns(path, vertex, scale_names, hi=math.log(MAX_MAGNITUDE), allow_neg_inf=True,
                  expected=f"a log-scale <= {math.log(MAX_MAGNITUDE):.2f} (scale <= {MAX_MAGNITUDE:g})")
    # opacity logits +-inf are the limits alpha = 1 and 0 (PlayCanvas splat-transform writes +inf for alpha 255)
    check_columns(path, vertex, ["opacity"], allow_neg_inf=True, allow_pos_inf=True,
                  expected="a finite opacity logit or +-inf (alpha 1 or 0)")
    check_columns(path, vertex, ["f_dc_0", "f_dc_1", "f_dc_2", *rest_names])
    # normals: carried into every frame as they are, so a NaN would be in every frame (3DGS writes zeros)
    check_columns(path, vertex, [nm for nm in ("nx", "ny", "nz") if nm in vertex.dtype.names])
    q = stack_columns(vertex, ("rot_0", "rot_1", "rot_2", "rot_3"))
    norm = np.linalg.norm(q, axis=1)
    bad = ~(np.isfinite(norm) & (norm > 1e-12))
    if bad.any():
        reject_file(path, f"rot_0..rot_3: zero or non-finite quaternion at vertex {int(np.flatnonzero(bad)[0])}")
    return means, q / norm[:, None]


# --------------------------------------------------------------------------------------------
# PLY writing


def write_gaussians(path, g: Gaussians, *, overwrite: bool = False, layout: str = "3dgs") -> Path:
    """Write Gaussians as a graphdeco 3DGS PLY (binary little endian, float32).

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its directory must exist.
    g : Gaussians
    overwrite : bool
        Replace an existing file. Default False.
    layout : {"3dgs", "2dgs"}
        ``"3dgs"`` (default): properties ``x y z [nx ny nz] f_dc_0..2 f_rest_0..(3K-1) opacity
        scale_0..2 rot_0..3`` then the other ``g.extra`` properties in their order, so that
        standard viewers open it (GaMeS Gaussians are written this way too, ``scale_0 =
        log(1e-8)``). ``"2dgs"``: the 2DGS layout, two scales, undoing the column permutation
        :func:`read_gaussians` applied (thin axis column 0 -> normal column 2); ``scales[:, 0]``
        is dropped.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False; the message names the path.
    ValueError
        If ``layout`` is not ``"3dgs"`` or ``"2dgs"``.
    SceneError
        ``g`` holds what a :class:`Gaussians` refuses (its arrays changed after it was built: a NaN, a zero
        quaternion; :meth:`Gaussians.check`), named with ``path``; nothing is written.

    Notes
    -----
    Atomic: written to a temporary file in the same directory, flushed and fsynced, then
    ``os.replace``-d onto ``path``; on any error the temporary file is removed and ``path`` is
    untouched. Means, log-scales and unit rotations are cast from float64 to float32;
    opacities, SH and extras are written as stored (bit for bit). Scales of 0 are written as
    ``log(0) = -inf`` (exp gives 0 back).
    """
    if layout not in ("3dgs", "2dgs"):
        raise ValueError(f"write_gaussians: layout must be '3dgs' or '2dgs', got {layout!r}")
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path}: file exists; pass overwrite=True to replace it")
    g.check(str(path))
    n = g.n
    f4 = "<f4"
    cols = _ply_columns(g, layout)

    def ply_dtype(name, arr):
        if name in g.extra:
            return arr.dtype.newbyteorder("<")
        return np.dtype(f4)

    dtype = [(nm, ply_dtype(nm, arr)) for nm, arr in cols]
    data = np.empty(n, dtype=dtype)
    for nm, arr in cols:
        data[nm] = arr
    el = PlyElement.describe(data, "vertex")
    ply = PlyData([el], text=False, byte_order="<")

    atomic_write(path, ply.write, overwrite=overwrite)
    return path


def _ply_columns(g: Gaussians, layout: str) -> list[tuple[str, np.ndarray]]:
    """The vertex properties :func:`write_gaussians` writes, in order, with their values (see its ``layout``)."""
    n, k = g.n, g.sh_rest.shape[1]
    cols: list[tuple[str, np.ndarray]] = []
    for i, a in enumerate("xyz"):
        cols.append((a, g.means[:, i]))
    normals = [nm for nm in ("nx", "ny", "nz") if nm in g.extra]
    for nm in normals:
        cols.append((nm, g.extra[nm]))
    for i in range(3):
        cols.append((f"f_dc_{i}", g.sh_dc[:, i]))
    f_rest = g.sh_rest.transpose(0, 2, 1).reshape(n, 3 * k)  # channel-major
    for i in range(3 * k):
        cols.append((f"f_rest_{i}", f_rest[:, i]))
    cols.append(("opacity", g.opacities))
    with np.errstate(divide="ignore"):
        log_s = np.log(g.scales)
    q = g.rotations
    if layout == "2dgs":
        perm = tuple(g.meta.get("rotation_columns_from_file", _2DGS_PERM))
        inv = np.argsort(perm)
        q = rotmat_to_quat(quat_to_rotmat(q)[:, :, inv])
        log_s = log_s[:, [perm.index(0), perm.index(1)]]
    for i in range(log_s.shape[1]):
        cols.append((f"scale_{i}", log_s[:, i]))
    for i in range(4):
        cols.append((f"rot_{i}", q[:, i]))
    for nm, val in g.extra.items():
        if nm not in normals:
            cols.append((nm, val))
    return cols
