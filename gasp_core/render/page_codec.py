"""The compressed frames of the ``gasp view --export`` page: quantised, predicted from frame 0 and the frame
before, byte-planed for gzip; ``player.html`` decodes them in the browser, :func:`decode` in numpy.

Layout (little-endian; the page's metadata gives ``n``, ``m``, the offsets and the quantisation steps):

* the Gaussians in Morton order of their frame-0 centres (the page draws in depth order, so the order is
  free, and neighbours in the stream move alike);
* colours once, ``n x 4`` uint8 ``(r, g, b, opacity)`` (a run never changes appearance);
* ``m`` uint32 indices of the rows whose quantised values change in some frame; the rest are stored once;
* frame 0, all ``n`` rows, as 10 components: centres on a ``2**bits - 1`` grid over the sequence's box
  ``[lo, hi]``, each minus the previous row's; rotations ``w, x, y, z`` times :data:`Q0` (world frame);
  log scales on a :data:`LS0` grid over ``[log_lo, log_hi]``;
* every later frame, the ``m`` moving rows as 9 components (centre 3, rotation 3, log scale 3): each
  component's integer value minus the frame before's, centres and rotations further minus the previous
  moving row's step (neighbours move alike).

Every component is a run of integers, zigzag-coded (``0, -1, 1, -2 -> 0, 1, 2, 3``) to uint16 and written
as two byte planes, low bytes then high bytes (gzip finds the mostly-zero high bytes). The rotation at frame ``k`` is ``exp(v_k) q_0`` with ``v_k``
  a rotation vector in steps of ``rot_step`` radians; the log scale is frame 0's plus steps of
  ``log_step``.

What it costs (:func:`encode`'s ``errors``): a centre moves at most ``0.5 / (2**bits - 1)`` of the box's
longest side; a rotation turns at most about ``rot_step * sqrt(3) / 2`` (plus frame 0's 1e-3 rad); a scale
changes by at most ``exp(log_step / 2) - 1`` relative (plus frame 0's ``(log_hi - log_lo) / 8190``). The page decodes all frames into its memory once.
The scheme follows the ideas of PlayCanvas's compressed PLY and SOG (quantised centres in a box, log scales)
with time prediction as in video coding.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat

#: Defaults: 10-bit centres (11 made the README donut's page 5.07 MB, over its 5 MB; issue 55), 0.75 degree rotation steps, 2 % log-scale steps (:func:`encode`).
BITS, ROT_STEP, LOG_STEP = 10, float(np.radians(0.75)), 0.02
#: Frame 0's rotations (``w, x, y, z`` times Q0, rounded) and log scales (LS0 steps over the run's range).
Q0, LS0 = 2047.0, 4095.0


@dataclass
class Frames:
    """World-frame Gaussians of every frame of a run, as the page needs them.

    Attributes
    ----------
    means : ndarray, shape (F, n, 3), float64
        Centres, metres.
    quats : ndarray, shape (F, n, 4), float64
        Unit rotations, **wxyz**, world frame.
    scales : ndarray, shape (F, n, 3), float64
        Standard deviations along the local axes, metres (> 0).
    rgba : ndarray, shape (n, 4), float64
        Colour in [0, 1] (SH degree 0) and activated opacity of frame 0.
    """

    means: np.ndarray
    quats: np.ndarray
    scales: np.ndarray
    rgba: np.ndarray


def morton_order(p: np.ndarray, bits: int = 10) -> np.ndarray:
    """Indices sorting the points ``p`` (n, 3) along a Z-order (Morton) curve over their box, ``bits`` per axis."""
    span = max(float(np.ptp(p, axis=0).max()), 1e-12) if len(p) else 1.0
    q = np.clip((p - p.min(axis=0)) / span * (2 ** bits - 1), 0, 2 ** bits - 1).astype(np.int64)
    code = np.zeros(len(p), np.int64)
    for b in range(bits):
        for a in range(3):
            code |= ((q[:, a] >> b) & 1) << (3 * b + a)
    return np.argsort(code, kind="stable")


def _qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], -1)


def _rotvec(q):
    """Rotation vectors (..., 3) of unit quaternions (..., 4), angle in [0, pi]."""
    q = q * np.where(q[..., :1] < 0, -1.0, 1.0)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(s, q[..., :1])
    return np.where(s > 1e-12, q[..., 1:] / np.maximum(s, 1e-300) * ang, 2.0 * q[..., 1:])


def _quat_exp(v):
    a = np.linalg.norm(v, axis=-1, keepdims=True)
    k = np.where(a > 1e-12, np.sin(0.5 * a) / np.maximum(a, 1e-300), 0.5)
    return np.concatenate([np.cos(0.5 * a), v * k], axis=-1)


def _planes(res: np.ndarray) -> bytes:
    """Zigzag byte planes of the residuals ``res`` (c, m) int64 (module docstring)."""
    zig = np.where(res >= 0, 2 * res, -2 * res - 1)
    if zig.size and zig.max() > 0xFFFF:
        raise ValueError(f"page codec: a step of {int(np.abs(res).max())} quanta does not fit 16 bits")
    return b"".join(np.stack([(c & 0xFF).astype(np.uint8), (c >> 8).astype(np.uint8)]).tobytes() for c in zig)


def _unplanes(data: bytes, offset: int, c: int, m: int) -> np.ndarray:
    """Inverse of :func:`_planes`: ``c`` components of ``m`` values at ``offset`` -> (m, c) int64."""
    z = np.frombuffer(data, np.uint8, 2 * c * m, offset).reshape(c, 2, m).astype(np.int64)
    z = z[:, 0] + 256 * z[:, 1]
    return np.where(z & 1, -(z >> 1) - 1, z >> 1).T


def encode(fr: Frames, bits: int = BITS, rot_step: float = ROT_STEP, log_step: float = LOG_STEP):
    """Quantise and pack a run's frames for the page (module docstring).

    Parameters
    ----------
    fr : Frames
        All frames, world frame, metres.
    bits : int
        Centre bits per axis, 8 to 16.
    rot_step, log_step : float
        Rotation-vector step (radians) and log-scale step of frames after the first.

    Returns
    -------
    meta : dict
        ``n``, ``n_moving``, ``bits``, ``rot_step``, ``log_step``, ``lo``, ``hi``, ``size`` (m, longest side of
        the box), ``log_lo``, ``log_hi``, byte offsets ``moving_offset``, ``frames_offset``, ``deltas_offset``.
    data : bytes
        Before gzip.
    order : ndarray, shape (n,), int64
        The stored row ``j`` is input Gaussian ``order[j]``.

    Raises
    ------
    ValueError
        ``bits`` outside 8..16, or a frame-to-frame step too large for 16 bits (a rotation step under
        0.01 degrees).
    """
    if not 8 <= bits <= 16:
        raise ValueError(f"page codec: bits = {bits}; expected 8 to 16")
    order = morton_order(fr.means[0])
    means, quats = fr.means[:, order], fr.quats[:, order]
    logs = np.log(np.maximum(fr.scales[:, order], 1e-30))
    n, levels = means.shape[1], 2 ** bits - 1
    lo, hi = means.reshape(-1, 3).min(axis=0), means.reshape(-1, 3).max(axis=0)
    hi = np.maximum(hi, lo + 1e-9)
    qm = np.rint((means - lo) / (hi - lo) * levels).astype(np.int64)
    q0 = np.rint(quats[0] * np.where(quats[0][:, :1] < 0, -Q0, Q0)).astype(np.int64)
    log_lo, log_hi = float(logs.min()), float(max(logs.max(), logs.min() + 1e-6))
    ls0 = np.rint((logs[0] - log_lo) / (log_hi - log_lo) * LS0).astype(np.int64)
    q0_dec = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
    inv0 = q0_dec * [1.0, -1.0, -1.0, -1.0]
    rv = np.rint(_rotvec(_qmul(quats[1:], inv0[None])) / rot_step).astype(np.int64)
    ls0_dec = log_lo + ls0 / LS0 * (log_hi - log_lo)
    dl = np.rint((logs[1:] - ls0_dec) / log_step).astype(np.int64)
    later = np.concatenate([qm[1:], rv, dl], axis=2)                          # (F-1, n, 9)
    first = np.concatenate([qm[:1], np.zeros((1, n, 6), np.int64)], axis=2)
    moving = np.flatnonzero((later != first).any(axis=(0, 2))) if len(later) else np.zeros(0, np.int64)
    steps = np.diff(np.concatenate([first[:, moving], later[:, moving]]), axis=0)
    steps[:, 1:, :6] -= steps[:, :-1, :6].copy()            # centres, rotations: the previous row's step
    rgba = np.clip(fr.rgba[order], 0.0, 1.0)
    parts = [(rgba * 255.0 + 0.5).astype(np.uint8).tobytes(), moving.astype("<u4").tobytes(),
             _planes(np.concatenate([np.diff(qm[0], axis=0, prepend=0), q0, ls0], axis=1).T)]
    parts += [_planes(s.T) for s in steps]
    meta = {"n": n, "n_moving": len(moving), "bits": bits, "rot_step": rot_step, "log_step": log_step,
            "lo": lo.tolist(), "hi": hi.tolist(), "size": float(np.max(hi - lo)), "log_lo": log_lo,
            "log_hi": log_hi, "moving_offset": len(parts[0]), "frames_offset": len(parts[0]) + len(parts[1]),
            "deltas_offset": len(parts[0]) + len(parts[1]) + len(parts[2])}
    return meta, b"".join(parts), order


def decode(meta: dict, data: bytes, n_frames: int) -> Frames:
    """What the page shows: the frames of :func:`encode`'s output, in its (Morton) row order.

    Returns
    -------
    Frames
        ``means`` and ``scales`` in metres, ``quats`` unit **wxyz**, ``rgba`` in [0, 1].
    """
    n, m, levels = meta["n"], meta["n_moving"], 2 ** meta["bits"] - 1
    lo, hi = np.array(meta["lo"]), np.array(meta["hi"])
    rgba = np.frombuffer(data, np.uint8, 4 * n).reshape(n, 4) / 255.0
    moving = np.frombuffer(data, "<u4", m, meta["moving_offset"]).astype(np.int64)
    o = meta["frames_offset"]
    first = _unplanes(data, o, 10, n)
    qm, q0, ls0 = np.cumsum(first[:, :3], axis=0), first[:, 3:7] / Q0, first[:, 7:]
    q0 = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
    log0 = meta["log_lo"] + ls0 / LS0 * (meta["log_hi"] - meta["log_lo"])
    means, quats, scales = [lo + qm / levels * (hi - lo)], [q0], [np.exp(log0)]
    state, o = np.concatenate([qm[moving], np.zeros((m, 6), np.int64)], axis=1), meta["deltas_offset"]
    for _ in range(1, n_frames):
        step = _unplanes(data, o, 9, m)
        o += 18 * m
        step[:, :6] = np.cumsum(step[:, :6], axis=0)
        state = state + step
        mk, qk, sk = means[0].copy(), q0.copy(), scales[0].copy()
        mk[moving] = lo + state[:, :3] / levels * (hi - lo)
        qk[moving] = _qmul(_quat_exp(state[:, 3:6] * meta["rot_step"]), q0[moving])
        sk[moving] = np.exp(log0[moving] + state[:, 6:] * meta["log_step"])
        means.append(mk), quats.append(qk), scales.append(sk)
    return Frames(np.array(means), np.array(quats), np.array(scales), rgba)


def sqrt_cov(quats: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """``S = R diag(s) R^T`` (``S S`` is the covariance) as ``S00 S01 S02 S11 S12 S22`` (n, 6), metres."""
    R = quat_to_rotmat(quats)
    S = (R * scales[:, None, :]) @ R.transpose(0, 2, 1)
    return S[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def world_quats(R_place: np.ndarray, rotmats: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) wxyz of ``R_place @ rotmats`` (placement rotation applied to each Gaussian's)."""
    return rotmat_to_quat(np.einsum("ij,njk->nik", np.asarray(R_place, float), rotmats))
