"""antimatter15's splaTV dynamic format (Spacetime Gaussians "lite"): ``psi(V, s)`` at any time."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from gasp_core.gs.bound import check_count
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.ply import LOGIT_CLAMP, SH_C0, check_is_file, reject_file

_SPLATV_MAGIC = 0x674B
_SPLATV_RECORD = 64  # bytes per splat


# --------------------------------------------------------------------------------------------
# splaTV (dynamic)


def read_splatv(path) -> tuple[Gaussians, dict[str, np.ndarray]]:
    """Read an antimatter15 splaTV file (Spacetime Gaussians "lite", continuous time).

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    base : Gaussians
        ``layout = "splatv"``. The stored (time-independent) values: ``means`` = xyz at
        ``dt = 0``, rotations = the stored w,x,y,z normalised, ``scales`` = the stored linear
        scales, ``opacities`` = logit of the stored sigmoid byte (0 -> -40, 255 -> +40),
        ``sh_dc = (rgb - 0.5) / SH_C0``, no ``sh_rest``. ``meta["header"]`` holds the JSON
        header; ``extra["rot_norm"]`` (float64) the norm of the stored float16 quaternion, so
        that :func:`splatv_at` can rebuild it (it adds ``omega dt`` to the *unnormalised*
        quaternion before normalising, as the viewer does).
    motion : dict of str -> ndarray
        ``"motion"`` (n, 9) float32: polynomial coefficients (m[0:3] dt + m[3:6] dt^2 +
        m[6:9] dt^3); ``"omega"`` (n, 4) float32 (w,x,y,z rate); ``"trbf_center"`` (n,) float32;
        ``"trbf_scale"`` (n,) float32 (temporal RBF width, exp already applied; ``inf`` where
        float16 overflowed: always visible).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SceneError
        Wrong magic number, a header that is not JSON, a body that is not a whole number of
        64-byte records, or a non-finite position.

    Notes
    -----
    Layout, from antimatter15/splaTV ``hybrid.js`` (the vertex shader reads the texture built
    from these 16 uint32 words): uint32 magic ``0x674B``, uint32 header length L, L bytes of JSON,
    then records of 16 little-endian words: 0-2 float32 x, y, z; 3-4 float16 rot w,x,y,z;
    5-6 float16 sx, sy, sz (+1 unused); 7 RGBA8 (R in the low byte); 8-12 nine float16 motion
    (+1 unused); 13-14 float16 omega w,x,y,z; 15 float16 trbf_center, trbf_scale.
    """
    path = Path(path)
    header, body = _header_and_body(path)
    n = len(body) // _SPLATV_RECORD
    words = np.frombuffer(body, dtype="<u4").reshape(n, 16)
    halves = words.view("<f2").reshape(n, 32)  # half j of word w = column 2w + j (low half first)
    means = words[:, 0:3].view("<f4").astype(np.float64)
    bad = ~np.isfinite(means).all(axis=1)
    if bad.any():
        reject_file(path, f"non-finite position (x, y, z) at record {int(np.flatnonzero(bad)[0])}")
    raw_rot = halves[:, 6:10].astype(np.float32)
    scales = halves[:, 10:13].astype(np.float64)
    rgba = words[:, 7:8].view(np.uint8).reshape(n, 4).astype(np.float64) / 255.0
    motion = halves[:, 16:25].astype(np.float32)
    omega = halves[:, 26:30].astype(np.float32)
    trbf_center = halves[:, 30].astype(np.float32)
    trbf_scale = halves[:, 31].astype(np.float32)
    for name, arr in (("motion", motion), ("omega", omega), ("trbf_center", trbf_center)):
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.flatnonzero(bad.reshape(n, -1).any(axis=1))[0])
            reject_file(path, f"non-finite {name} at record {i}; expected finite float16 values")
    bad = np.isnan(trbf_scale) | (trbf_scale < 0)
    if bad.any():
        reject_file(path, f"trbf_scale = {trbf_scale[bad][0]} at record {int(np.flatnonzero(bad)[0])}; expected >= 0")
    a = rgba[:, 3]
    with np.errstate(divide="ignore"):
        opac = np.where(a <= 0, -LOGIT_CLAMP, np.where(a >= 1, LOGIT_CLAMP, -np.log(1.0 / a - 1.0)))
    raw_rot = raw_rot.astype(np.float64)
    base = Gaussians(means=means, scales=scales, rotations=raw_rot,
                     opacities=opac.astype(np.float32),
                     sh_dc=((rgba[:, :3] - 0.5) / SH_C0).astype(np.float32),
                     extra={"rot_norm": np.linalg.norm(raw_rot, axis=1)},
                     source=str(path), layout="splatv", meta={"header": header})
    return base, {"motion": motion, "omega": omega, "trbf_center": trbf_center,
                  "trbf_scale": trbf_scale}


def _header_and_body(path: Path) -> tuple[object, bytes]:
    """The JSON header of a splaTV file and its body of whole 64-byte records; :class:`SceneError` for a wrong
    magic number, a header that is not JSON or a truncated file."""
    check_is_file(path, "splaTV file")
    with open(path, "rb") as f:
        head = f.read(8)
    if len(head) < 8:
        reject_file(path, f"splaTV file of {len(head)} bytes; expected at least an 8-byte header")
    magic, hlen = struct.unpack_from("<II", head, 0)
    if magic != _SPLATV_MAGIC:
        reject_file(path, f"magic 0x{magic:x}; expected 0x{_SPLATV_MAGIC:x} (a splaTV file)")
    check_count(path, path.stat().st_size // _SPLATV_RECORD, "its size")   # bounded before it is read
    raw = path.read_bytes()
    if 8 + hlen > len(raw):
        reject_file(path, f"header length {hlen} runs past the end of the file ({len(raw)} bytes); truncated?")
    try:
        header = json.loads(raw[8:8 + hlen].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:   # nested 200,000 deep: RecursionError
        reject_file(path, f"header is not JSON: {type(exc).__name__}: {str(exc)[:200]}")
    body = raw[8 + hlen:]
    if len(body) % _SPLATV_RECORD:
        reject_file(path, f"body of {len(body)} bytes is not a whole number of {_SPLATV_RECORD}-byte "
                    "records; truncated?")
    return header, body


def splatv_at(base: Gaussians, motion: dict[str, np.ndarray], t: float) -> Gaussians:
    """The splaTV model at time ``t``.

    Parameters
    ----------
    base : Gaussians
        From :func:`read_splatv`.
    motion : dict
        From :func:`read_splatv` (``motion``, ``omega``, ``trbf_center``, ``trbf_scale``).
    t : float
        Normalised time, usually in [0, 1].

    Returns
    -------
    Gaussians
        ``dt = t - trbf_center``; ``means = xyz + m[0:3] dt + m[3:6] dt^2 + m[6:9] dt^3``;
        ``rotations = normalise(rot + omega dt)``; scales, colour unchanged; opacity multiplied
        by ``exp(-(dt / trbf_scale)^2)`` (applied to ``sigmoid(logit)`` and turned back into a
        logit). ``extra["temporal_opacity"]`` (float32) holds that factor (the viewer skips a
        splat whose factor is below 0.02); ``extra["rot_norm"]`` the norm of ``rot + omega dt``.

    Notes
    -----
    Formulas of antimatter15/splaTV ``hybrid.js`` (vertex shader: ``tpos``, ``trot``,
    ``topacity``), after Spacetime Gaussians (Li et al. 2024, polynomial motion and temporal
    RBF opacity).
    """
    dt = float(t) - motion["trbf_center"].astype(np.float64)
    m = motion["motion"].astype(np.float64)
    d1, d2, d3 = dt[:, None], (dt * dt)[:, None], (dt * dt * dt)[:, None]
    means = base.means + m[:, 0:3] * d1 + m[:, 3:6] * d2 + m[:, 6:9] * d3
    raw = base.rotations * base.extra.get("rot_norm", np.ones(base.n))[:, None]
    rot = raw + motion["omega"].astype(np.float64) * d1
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        factor = np.exp(-(dt / motion["trbf_scale"].astype(np.float64)) ** 2)
    factor = np.where(np.isfinite(factor), factor, 1.0)
    alpha = 1.0 / (1.0 + np.exp(-base.opacities.astype(np.float64))) * factor
    with np.errstate(divide="ignore"):
        opac = np.where(alpha <= 0, -LOGIT_CLAMP,
                        np.where(alpha >= 1, LOGIT_CLAMP, np.log(alpha) - np.log1p(-alpha)))
    g = base.copy()
    g.means, g.opacities = means, opac.astype(np.float32)
    norm = np.linalg.norm(rot, axis=1)
    g.extra = dict(g.extra, rot_norm=norm, temporal_opacity=factor.astype(np.float32))
    g.meta = dict(g.meta, time=float(t))
    # rebuild through the constructor: validates and normalises the rotation
    return Gaussians(means=g.means, scales=g.scales, rotations=rot, opacities=g.opacities,
                     sh_dc=g.sh_dc, sh_rest=g.sh_rest, extra=g.extra, source=g.source,
                     layout="splatv", meta=g.meta)




#: Model time at which a dynamic model is read as one frame (``gasp info``, :func:`read_splatv_middle`).
MIDDLE_TIME = 0.5


def read_splatv_middle(path, fmt: str = "splatv") -> Gaussians:
    """A splaTV file as one frame: :func:`splatv_at` at model time :data:`MIDDLE_TIME` (the registry's reader;
    ``gasp info`` describes it so). A scene simulates the model from its ``dynamic_time`` instead.

    Raises
    ------
    FileNotFoundError, SceneError
        As :func:`read_splatv`.
    """
    base, motion = read_splatv(path)
    return splatv_at(base, motion, MIDDLE_TIME)
