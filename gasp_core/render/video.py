"""Write rendered frames: MP4 (imageio-ffmpeg), GIF (Pillow) or a folder of PNGs, atomically."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

import numpy as np

from gasp_core.fsutil import atomic_path, output_folder

from gasp_core.errors import SceneError

VIDEO_SUFFIXES = (".mp4", ".gif")


def _check_target(out: Path, overwrite: bool) -> None:
    if out.exists() and not overwrite:
        raise SceneError(f"output '{out}' exists; pass --overwrite to replace it")
    if not out.parent.exists():
        raise SceneError(f"output '{out}': folder '{out.parent}' does not exist")


def write_frames(frames: Iterable[np.ndarray], output, fps: float = 30.0, overwrite: bool = False) -> Path:
    """Write uint8 RGB frames (h, w, 3) to ``output``: ``.mp4``, ``.gif``, else a PNG folder.

    MP4 is H.264 (yuv420p, through imageio-ffmpeg); GIF loops forever; the folder holds
    ``frame_0000.png ...``. The output appears only once complete (temporary name, then rename).

    Raises
    ------
    SceneError
        ``output`` exists and ``overwrite`` is false, its folder is missing, no frame was given, or an
        error without a file name (a full disk) while writing it.
    ImportError
        For ``.mp4`` without imageio-ffmpeg (``pip install -e ".[render]"``).
    """
    out = Path(output)
    _check_target(out, overwrite)
    try:
        if out.suffix.lower() in VIDEO_SUFFIXES:
            _write_video(out, frames, fps)
        else:
            _write_folder(out, frames, overwrite)
    except OSError as e:    # an error without a file name (a full disk while writing) names the output
        if e.filename:
            raise
        raise SceneError(f"output '{out}': {e.strerror or e}") from e
    return out


def _write_video(out: Path, frames: Iterable[np.ndarray], fps: float) -> int:
    """``out`` (``.mp4`` or ``.gif``) written atomically from ``frames``; their count (nothing written at 0)."""
    import imageio.v3 as iio
    with atomic_path(out, overwrite=True) as tmp:
        if out.suffix.lower() == ".mp4":
            import imageio.v2 as iio2
            count = 0
            with iio2.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264", quality=8,
                                 pixelformat="yuv420p", macro_block_size=8) as w:
                for img in frames:
                    w.append_data(img)
                    count += 1
        else:   # encoded in memory, then written: a full disk is one OSError, not a writer's __del__ traceback
            stack = [img for img in frames]
            count = len(stack)
            if count:
                data = iio.imwrite("<bytes>", np.stack(stack), extension=".gif", duration=1000.0 / fps, loop=0)
                with open(tmp, "wb") as f:
                    f.write(data)
        if count == 0:
            raise SceneError(f"output '{out}': no frames to write")   # leaves nothing behind
    return count


def _write_folder(out: Path, frames: Iterable[np.ndarray], overwrite: bool) -> int:
    """A folder ``out`` of ``frame_0000.png ...`` written atomically from ``frames``; their count."""
    import imageio.v3 as iio
    with output_folder(out, overwrite=overwrite) as tmpdir:
        count = 0
        for i, img in enumerate(frames):
            iio.imwrite(tmpdir / f"frame_{i:04d}.png", img)
            count += 1
        if count == 0:
            raise SceneError(f"output '{out}': no frames to write")
    return count


def write_png(img: np.ndarray, output) -> Path:
    """Write one uint8 RGB image atomically (replaces an existing file)."""
    import imageio.v3 as iio
    out = Path(output)
    with atomic_path(out, overwrite=True) as tmp:
        iio.imwrite(tmp, img)
    return out
