"""Checkpoints of a running simulation, so that ``gasp simulate --resume`` continues a killed run.

After every frame whose PLYs are written, the pipeline saves the engine's state (engines with
the feature ``state``, a :class:`~gasp_core.seam.engine.StatefulEngine`: ``get_state`` /
``set_state``), the frame rebuild's state (the previous rotations, the fallback of ``T^-1`` for
degenerate faces), the pieces' state (their cut links, :mod:`gasp_core.run.pieces`) and the run record so far to
``.gasp-checkpoint.npz`` in the partial folder,
atomically. A run killed at any point (even ``kill -9``) therefore loses at most the frame it was
computing. ``--resume`` finds the partial folder of a run that is no longer alive, checks that the
scene, its inputs, the engine and its options are the same (a fingerprint), restores the state and
goes on; on an engine that is deterministic the resumed frames equal an uninterrupted run bit for bit.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gasp_core.errors import GaspError
from gasp_core.fsutil import atomic_write, leftover_partials
from gasp_core.prepare.scene import input_files

CHECKPOINT = ".gasp-checkpoint.npz"
#: A run checkpoints every frame while an engine's state takes at most this many bytes, and every
#: ``ceil(bytes / CHECKPOINT_BYTES)`` frames beyond (issue 65: 2M points' 200 MB took 1.7-2.3 s a frame to write on
#: 2 cores, now every 4th frame; a 16M-point body's 1.6 GB every 25th); ``GASP_CHECKPOINT_MB`` in the environment
#: sets it (MB).
CHECKPOINT_BYTES = 64 << 20


def checkpoint_every(state: dict) -> int:
    """Frames between checkpoints for an engine state (a dict of arrays, the first frame's), at least 1."""
    limit = float(os.environ.get("GASP_CHECKPOINT_MB", CHECKPOINT_BYTES / 2 ** 20)) * 2 ** 20
    size = sum(np.asarray(a).nbytes for a in state.values())
    return max(1, int(np.ceil(size / max(limit, 1.0))))


@dataclass
class Checkpoint:
    """The state after ``frame`` (whose PLYs are written).

    Attributes
    ----------
    frame : int
    engine_state : dict of ndarray
        From the engine's ``get_state()``.
    prev_rot : list of ndarray, shapes (n_k, 3, 3)
        Per object, the world rotations of ``frame`` (the rebuild's fallback).
    meta : dict
        ``fingerprint``, ``per_frame`` rows, ``build_s`` and ``frame_s`` so far.
    pieces : dict of ndarray
        The piece tracker's state after ``frame`` (:meth:`gasp_core.run.pieces.PieceTracker.state`: its cut links
        stay cut); empty without a brittle body.
    """

    frame: int
    engine_state: dict[str, np.ndarray]
    prev_rot: list[np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)
    pieces: dict[str, np.ndarray] = field(default_factory=dict)


def fingerprint(scene, engine: str, options: dict, n_frames: int, output: tuple = ("ply", "frames")) -> str:
    """SHA-256 of what a resumed run must share with the killed one: its inputs, engine, options, frames
    and output (format, layout).

    The inputs are exactly the files the run reads (:func:`gasp_core.prepare.scene.input_files`: the
    scene, every object's file, selection masks, collider meshes and Gaussians), each stood for by
    its path, size (bytes) and modification time (ns), as ``make`` and ``rsync`` take them: no file
    is read a second time for this (the object files can be gigabytes), and any edit, copy or
    ``touch`` of an input between the kill and ``--resume`` refuses the resume.

    Raises
    ------
    OSError
        An input file has gone (the run that follows would fail on it too).
    """
    h = hashlib.sha256()
    for p in input_files(scene):
        st = p.stat()
        h.update(f"{p.resolve()}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
    h.update(json.dumps([engine, options, n_frames, *([] if tuple(output) == ("ply", "frames") else output)],
                        sort_keys=True, default=str).encode())
    return h.hexdigest()


def save(folder: Path, checkpoint: Checkpoint) -> None:
    """Write ``folder/.gasp-checkpoint.npz`` atomically (the previous checkpoint stays until replaced)."""
    arrays = {f"engine/{k}": np.asarray(v) for k, v in checkpoint.engine_state.items()}
    arrays.update({f"rot/{i}": r for i, r in enumerate(checkpoint.prev_rot)})
    arrays.update({f"pieces/{k}": np.asarray(v) for k, v in checkpoint.pieces.items()})
    meta = dict(checkpoint.meta, frame=checkpoint.frame, n_rot=len(checkpoint.prev_rot))
    arrays["meta"] = np.frombuffer(json.dumps(meta, default=str).encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write(folder / CHECKPOINT, lambda f: f.write(buf.getbuffer()))


def load(folder: Path) -> Checkpoint:
    """Read a checkpoint.

    Raises
    ------
    GaspError
        The file is missing or unreadable (the message names it).
    """
    path = folder / CHECKPOINT
    try:
        with np.load(path) as z:
            meta = json.loads(bytes(z["meta"]).decode())
            if not isinstance(meta, dict):
                raise ValueError(f"meta is {type(meta).__name__}, not a table")
            for key in ("frame", "n_rot"):
                if not isinstance(meta.get(key), int) or isinstance(meta[key], bool) or meta[key] < 0:
                    raise ValueError(f"meta {key} = {meta.get(key)!r}, not a count")
            if not isinstance(meta.get("per_frame", []), list) or not isinstance(meta.get("files", {}), dict):
                raise ValueError("meta per_frame or files of the wrong type")
            engine_state = {k[len("engine/"):]: z[k] for k in z.files if k.startswith("engine/")}
            prev_rot = [z[f"rot/{i}"] for i in range(meta["n_rot"])]
            piece_state = {k[len("pieces/"):]: z[k] for k in z.files if k.startswith("pieces/")}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, RecursionError) as e:
        raise GaspError(f"cannot resume from '{path}': the checkpoint is truncated or damaged ({e}); "
                        f"start again with --discard") from None
    return Checkpoint(meta["frame"], engine_state, prev_rot, meta, piece_state)


def file_record(folder: Path, rels, known: dict | None = None) -> dict[str, list[int]]:
    """``{rel: [size, crc32]}`` of the files ``rels`` (relative to ``folder``) not in ``known`` yet.

    A checkpoint keeps this record of every finished frame's files; :func:`check_files` compares.
    """
    out = {}
    for rel in rels:
        if known is not None and rel in known or rel in out:
            continue
        crc = 0
        with open(folder / rel, "rb") as f:
            while chunk := f.read(1 << 20):
                crc = zlib.crc32(chunk, crc)
        out[rel] = [(folder / rel).stat().st_size, crc]
    return out


def check_files(folder: Path, checkpoint: Checkpoint) -> None:
    """Refuse (:class:`GaspError`) to resume when a finished frame's file is missing or differs from its record.

    Checked against the checkpoint's ``files`` (:func:`file_record`: size and CRC-32); a checkpoint of an
    older gasp without it is taken as it is.
    """
    for rel, (size, crc) in checkpoint.meta.get("files", {}).items():
        try:
            now = file_record(folder, [rel])[rel]
        except OSError:
            raise GaspError(f"cannot resume '{folder}': '{rel}', a file of the finished frames, is missing; start "
                            f"again with --discard") from None
        if now != [size, crc]:
            raise GaspError(f"cannot resume '{folder}': '{rel}', a file of the finished frames, changed since it was "
                            f"written ({now[0]} bytes, was {size}); start again with --discard")


def remove_temporaries(folder: Path) -> None:
    """Remove the temporary files a killed run's atomic writes left in ``folder`` and its object folders
    (``..gasp-checkpoint.npz.*.tmp``, ``.frame_0003.ply.*.tmp``): :func:`gasp_core.fsutil.atomic_write`
    removes its own on any exception, but ``kill -9`` gives it no chance."""
    for p in [*folder.glob(".*.tmp"), *folder.glob("*/.*.tmp")]:
        p.unlink(missing_ok=True)


def refuse_unresumable(outdir: Path) -> None:
    """Refuse ``--resume`` of an output folder that holds a finished run and no killed one, or a run which
    diverged (``run.json`` ``status: "diverged"``, kept by :func:`gasp_core.run.pipeline.simulate_scene`): the
    first has nothing to resume (issue 55: it was called a blow-up), the second has no checkpoint, and going on
    from its last frame would blow up again.

    Raises
    ------
    GaspError
        ``outdir/run.json`` says the run diverged (the message names the frame and what to do), or it is a finished
        run and no partial folder of a killed run with a checkpoint lies beside it (the message says so, and what
        ``--overwrite`` would do).
    """
    try:
        record = json.loads((Path(outdir) / "run.json").read_text())
        status = record.get("status")
        diverged = record.get("diverged") if status == "diverged" else None
    except (OSError, ValueError, TypeError, KeyError, AttributeError, RecursionError):
        return                               # no readable run.json: find_resumable looks for a killed run
    if status != "diverged":
        if not any((p / CHECKPOINT).exists() for p in leftover_partials(outdir)):
            raise GaspError(_finished_message(Path(outdir), record))
        return
    frame = diverged.get("frame") if isinstance(diverged, dict) else None
    raise GaspError(f"cannot resume '{outdir}': its run diverged at frame {frame} and a blow-up is not resumed (it "
                    f"would come again); its frames before it are kept there; change the scene (a smaller time step, "
                    f"a softer material, walls) and run again with --overwrite, or with another -o")


def _finished_message(outdir: Path, record: dict) -> str:
    """The line for ``--resume`` of a folder that holds a finished run and no killed one: what is there and what
    ``--overwrite`` would do instead."""
    n = record.get("n_frames")
    frames = f"{n} frames, " if isinstance(n, int) else ""
    return (f"nothing to resume for '{outdir}': the run there is finished ({frames}{outdir / 'run.json'}) and no "
            f"killed run's partial folder lies beside it. --overwrite (without --resume) would simulate the scene "
            f"again from frame 0 and replace those frames once the new run finishes; another -o keeps them")


def find_resumable(outdir: Path, run_fingerprint: str) -> tuple[Path, Checkpoint]:
    """The partial folder of a killed run to ``outdir`` with a checkpoint of fingerprint ``run_fingerprint``.

    Raises
    ------
    GaspError
        None is found, or the checkpoints found belong to another scene, input or setting.
    """
    candidates = [p for p in leftover_partials(outdir) if (p / CHECKPOINT).exists()]
    if not candidates:
        raise GaspError(f"nothing to resume for '{outdir}': no partial folder of a killed run with a checkpoint "
                        f"(.{outdir.name}.partial-*/{CHECKPOINT}); run without --resume")
    others = []
    for p in sorted(candidates, key=lambda p: (p / CHECKPOINT).stat().st_mtime, reverse=True):
        checkpoint = load(p)
        if checkpoint.meta.get("fingerprint") == run_fingerprint:
            remove_temporaries(p)
            return p, checkpoint
        others.append(p.name)
    raise GaspError(f"cannot resume '{outdir}': the partial run(s) {others} were made from another scene, input "
                    f"file, engine, option or frame count; run without --resume")
