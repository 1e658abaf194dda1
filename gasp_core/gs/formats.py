"""Splat files other than PLY: Niantic ``.spz``, PlayCanvas ``.sog``, antimatter15 ``.splat`` and
mkkellogg ``.ksplat`` in; ``.spz``, compressed PLY and ``.sog`` out.

:func:`read_splat_file` reads any of them (:func:`gasp_core.gs.io.read_gaussians` hands it every
file that is not a PLY, through :mod:`gasp_core.gs.registry`, which tells the format from the file's first
bytes where it has a signature, else its suffix).

Which code reads what:

=================  ===================================  ========================================
format             read by                              written by
=================  ===================================  ========================================
``.spz``           gsply ``read_spz`` (optional extra)  gsply ``write_spz`` (v3, gzip); RUB axes
``.sog``           gsply ``sogread`` (+ imagecodecs)    :mod:`gasp_core.gs.sog` (own, Pillow WebP)
compressed PLY     :mod:`gasp_core.gs.compressed`       gsply ``compress_to_bytes``
``.splat``         :mod:`gasp_core.gs.splat` (own)      --
``.ksplat``        :mod:`gasp_core.gs.splat` (own)      --
=================  ===================================  ========================================

gsply (PyPI, MIT) is optional: ``pip install -e ".[formats]"``. Without it, reading or writing a
format that needs it raises one line naming the file and that command.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.errors import GaspError, extra_hint
from gasp_core.fsutil import atomic_path, atomic_write
from gasp_core.gs.gaussians import MAX_MAGNITUDE, Gaussians
from gasp_core.gs.ply import reject_file
from gasp_core.gs.sog_check import sog_bytes
from gasp_core.gs.spz_check import check_spz

def install_line() -> str:
    """The formats extra's ``pip install`` line (:func:`gasp_core.errors.extra_hint`)."""
    return extra_hint("formats")


def gsply_module(path, doing: str):
    """The ``gsply`` module, or :class:`GaspError` naming ``path``, what needed it and the install command."""
    try:
        import gsply
    except ImportError:
        raise GaspError(f"{path}: {doing} needs gsply, which is not installed ({install_line()})") from None
    return gsply


def read_splat_file(path, fmt: str | None = None) -> Gaussians:
    """Read a ``.spz``, ``.sog`` (bundle, folder or ``meta.json``), ``.splat`` or ``.ksplat`` file
    (the readers of those records of :mod:`gasp_core.gs.registry`).

    Parameters
    ----------
    path : str or os.PathLike
    fmt : str, optional
        The format's name, if already known (:func:`gasp_core.gs.registry.sniff`).

    Returns
    -------
    Gaussians
        ``layout`` = the format name; means float64 in file units, activated scales, unit wxyz
        rotations, opacity logits and SH as decoded (float32). ``source = str(path)``.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    SceneError
        A corrupt or truncated file (one line naming it), or an unknown format.
    GaspError
        ``.spz`` / ``.sog`` without gsply (the message gives the install command).
    """
    path = Path(path)
    if fmt is None:
        from gasp_core.gs.registry import sniff
        fmt = sniff(path).name
    if fmt in ("splat", "ksplat"):
        from gasp_core.gs.splat import read_ksplat, read_splat
        return check_decoded(path, read_splat(path) if fmt == "splat" else read_ksplat(path))
    gsply = gsply_module(path, f"reading a .{fmt} file")
    if fmt not in ("spz", "sog"):
        raise ValueError(f"not a format read here: {fmt}")
    if fmt == "spz":
        check_spz(path)          # in bounded memory, before gsply decompresses it whole
    else:
        data = sog_bytes(path)   # checked, and only the entries meta.json names
    try:
        if fmt == "spz":
            d = gsply.read_spz(path)
        else:
            from gsply.sog_reader import sogread
            d = sogread(data)
    except ImportError:  # sogread without imagecodecs: gsply's own install lines are left out (one line, ours)
        raise GaspError(f"{path}: reading a .sog file needs imagecodecs, which is not installed ({install_line()})") from None
    except Exception as e:   # gsply and its decoders raise many kinds (zip, JSON, WebP, numba) for a corrupt file
        why = str(e).replace(f": {path}", "").replace(str(path), "the file")     # the path is said once, first
        reject_file(path, f"not a readable .{fmt} file (truncated or corrupt?): {type(e).__name__}: {why}")
    g = check_decoded(path, from_gsdata(d, path, fmt))
    return flip_yz(g) if fmt == "spz" else g


def check_decoded(path, g: Gaussians) -> Gaussians:
    """``g`` as decoded from a file that is not a PLY, after refusing (one :class:`SceneError` line naming the
    file, the field and the splat) what the PLY reader refuses too: a position or scale that is not finite or
    beyond :data:`~gasp_core.gs.gaussians.MAX_MAGNITUDE`, a negative scale, a colour or SH coefficient that
    is not finite, a NaN opacity. A file of no splats reads as no Gaussians, as a PLY of 0 vertices does (round 102:
    a ``.spz`` gasp wrote of none was refused as "0 splats"); a scene refuses it
    (:func:`gasp_core.prepare.checks.check_object`: "the file has 0 Gaussians; nothing to simulate")."""
    if g.n == 0:
        return g
    fields = (("position", g.means, True), ("scale", g.scales, True), ("colour", g.sh_dc, False),
              ("SH coefficient", g.sh_rest.reshape(g.n, -1), False))
    with np.errstate(invalid="ignore"):
        for what, a, bounded in fields:
            bad = ~np.isfinite(a).all(axis=1)
            if bounded:
                bad |= (np.abs(a) > MAX_MAGNITUDE).any(axis=1)
            if what == "scale":
                bad |= (a < 0).any(axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                reject_file(path, f"{what} {a[i].tolist()} at splat {i}: expected finite values"
                            + (f" within {MAX_MAGNITUDE:g}" if bounded else "") + (", not negative" if what == "scale"
                                                                                  else ""))
    if np.isnan(g.opacities).any():
        reject_file(path, f"NaN opacity at splat {int(np.flatnonzero(np.isnan(g.opacities))[0])}")
    return g


#: Sign of each SH rest coefficient (degree 1, 2, 3 order of graphdeco) under ``y -> -y, z -> -z``
#: (Niantic spz ``coordinateConverter``: ``flipSh = {y, z, x, xy, yz, 1, xz, 1, y, xyz, y, z, x, z, x}``).
_SH_FLIP = np.array([-1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1], np.float32)


def flip_yz(g: Gaussians) -> Gaussians:
    """``g`` turned 180 degrees about x (``y -> -y``, ``z -> -z``): between PLY's RDF axes and SPZ's RUB.

    The SPZ specification stores right-up-back axes; its reference library (nianticlabs/spz, used by
    splat-transform and SuperSplat) converts from and to the PLY's right-down-front axes on save and
    load. gsply 0.4.6 stores the values as given, so GASP converts around it: means and the
    quaternion's y, z change sign, and the SH rest coefficients by :data:`_SH_FLIP`. It is its own
    inverse.
    """
    k = g.sh_rest.shape[1]
    return Gaussians(means=g.means * [1.0, -1.0, -1.0], scales=g.scales,
                     rotations=g.rotations * [1.0, 1.0, -1.0, -1.0], opacities=g.opacities, sh_dc=g.sh_dc,
                     sh_rest=g.sh_rest * _SH_FLIP[:k, None], extra=g.extra, source=g.source, layout=g.layout,
                     meta=g.meta)


def from_gsdata(d, path, layout: str) -> Gaussians:
    """A :class:`Gaussians` from a gsply ``GSData`` in its PLY convention (log-scales, logit opacities, wxyz)."""
    n = len(d.means)
    sh_rest = np.zeros((n, 0, 3), np.float32) if d.shN is None or np.asarray(d.shN).size == 0 \
        else np.asarray(d.shN, np.float32).reshape(n, -1, 3)
    q = np.asarray(d.quats, np.float64)
    norm = np.linalg.norm(q, axis=1)
    bad = ~(np.isfinite(norm) & (norm > 1e-12))
    if bad.any():
        reject_file(path, f"zero or non-finite quaternion at splat {int(np.flatnonzero(bad)[0])}")
    with np.errstate(over="ignore"):
        scales = np.exp(np.asarray(d.scales, np.float64))
    return Gaussians(means=np.asarray(d.means, np.float64), scales=scales, rotations=q / norm[:, None],
                     opacities=np.asarray(d.opacities, np.float32).reshape(n),
                     sh_dc=np.asarray(d.sh0, np.float32), sh_rest=sh_rest, source=str(path), layout=layout)


def gsply_arrays(g: Gaussians) -> tuple[np.ndarray, ...]:
    """``means, log_scales, quats (wxyz), opacities, sh0, shN (n, K, 3)`` as float32 arrays, gsply's PLY convention."""
    with np.errstate(divide="ignore"):
        log_s = np.log(g.scales)
    return (g.means.astype(np.float32), log_s.astype(np.float32), g.rotations.astype(np.float32),
            g.opacities.astype(np.float32), g.sh_dc.astype(np.float32), g.sh_rest.astype(np.float32))


def write_compressed_ply(path, g: Gaussians, *, overwrite: bool = False) -> Path:
    """:func:`write_splat_file` with ``fmt = "compressed_ply"`` (the registry's writer)."""
    return write_splat_file(path, g, "compressed_ply", overwrite=overwrite)


def write_spz(path, g: Gaussians, *, overwrite: bool = False) -> Path:
    """:func:`write_splat_file` with ``fmt = "spz"`` (the registry's writer)."""
    return write_splat_file(path, g, "spz", overwrite=overwrite)


#: Largest coordinate SPZ holds, file units: gsply writes signed 24-bit fixed point with 12 fractional bits and clamps
#: anything beyond (2^23 - 1) / 2^12 to it.
SPZ_MAX_COORD = ((1 << 23) - 1) / (1 << 12)


def _check_spz_range(path, g: Gaussians) -> None:
    """Refuse (:class:`SceneError`) a mean SPZ would clamp: one line naming the file, the row and the range."""
    far = np.abs(g.means) > SPZ_MAX_COORD - 0.5 / (1 << 12)   # rounds past the last step
    if far.any():
        i = int(np.flatnonzero(far.any(axis=1))[0])
        reject_file(path, f"Gaussian at index {i} is at {g.means[i].tolist()}; SPZ holds coordinates within "
                    f"+-{SPZ_MAX_COORD:.4f} (2048) file units and would clamp it: write another format (ply, sog, "
                    "compressed_ply) or move the object nearer the origin")


def write_splat_file(path, g: Gaussians, fmt: str, *, overwrite: bool = False) -> Path:
    """Write ``g`` as one file of format ``fmt`` (``compressed_ply``, ``spz`` or ``sog``), atomically.

    Parameters
    ----------
    path : path-like
        Destination; its folder must exist.
    g : Gaussians
    fmt : {"compressed_ply", "spz", "sog"}
        (``ply`` is :func:`gasp_core.gs.io.write_gaussians`.) ``compressed_ply``:
        PlayCanvas compressed PLY by gsply (positions 11/10/11 bits per 256-splat chunk). ``spz``:
        Niantic SPZ v3 by gsply (positions 24-bit fixed point, 12 fractional bits: 2.4e-4 file
        units; scales, colours, opacity 8 bit), in the specification's RUB axes (:func:`flip_yz`).
        ``sog``: :func:`gasp_core.gs.sog.write_sog`.
    overwrite : bool
        Replace an existing file.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    ValueError
        Unknown ``fmt``.
    GaspError
        ``compressed_ply`` / ``spz`` without gsply.
    SceneError
        ``spz``: a coordinate beyond :data:`SPZ_MAX_COORD` (the 24-bit fixed point would clamp it to the edge).
    """
    path = Path(path)
    if fmt == "sog":
        from gasp_core.gs.sog import write_sog
        return write_sog(path, g, overwrite=overwrite)
    if fmt not in ("compressed_ply", "spz"):
        raise ValueError(f"unknown format {fmt!r}; expected compressed_ply, spz or sog")
    gsply = gsply_module(path, f"writing {fmt}")
    if fmt == "spz":
        _check_spz_range(path, g)
        g = flip_yz(g)
    means, log_s, q, opac, sh0, shn = gsply_arrays(g)
    # the encoders need finite values: a zero scale (log = -inf) is stored as exp(-30)
    data = gsply.GSData(means=means, scales=np.maximum(log_s, np.float32(-30.0)), quats=q, opacities=opac, sh0=sh0,
                        shN=shn)
    if fmt == "compressed_ply":
        raw = gsply.compress_to_bytes(data)
        return atomic_write(path, lambda f: f.write(raw), overwrite=overwrite)
    with atomic_path(path, overwrite=overwrite) as tmp:
        gsply.write_spz(tmp, data)
    return path
