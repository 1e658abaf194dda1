"""The errors of GASP's error contract (``docs/writing_an_engine.md``, "Errors").

========================  ==============================================  ==========
raised                    meaning                                          CLI exit
========================  ==============================================  ==========
:class:`SceneError`       the input is wrong or unsupported (scene key,    2
                          file, a material or feature the engine lacks)
:class:`EngineError`      the engine cannot run here (package missing,     2
                          device absent, closed engine)
:class:`EngineDivergence` the simulation blew up (NaN, points left the     3
                          domain, energy gained); names the frame and the
                          likely cause
:class:`EngineBug`        anything else an engine raised: a bug in the     4
                          engine, reported with its traceback saved
========================  ==============================================  ==========
"""
from __future__ import annotations

import os
import re
from pathlib import Path


class GaspError(Exception):
    """Base class of every error GASP raises on purpose."""


class SceneError(GaspError, ValueError):
    """A scene file or its input is wrong; the message names the key, field or file."""


class EngineError(GaspError, RuntimeError):
    """An engine cannot run the scene (missing capability, unavailable device)."""


class EngineDivergence(GaspError, RuntimeError):
    """The simulation blew up: non-finite values, points leaving the domain, or energy gained
    (:mod:`gasp_core.seam.energy_watch`).

    Attributes
    ----------
    frame : int
        The frame (1-based, the first frame after the initial state) at which it was detected.
    cause : str
        The likely cause, in words (time step too large, stiffness too high, ...).
    kept : Path or None
        Where ``gasp simulate`` kept the frames written before the blow-up (the output folder, finalised with
        ``run.json`` ``status: "diverged"``; :func:`gasp_core.run.pipeline.simulate_scene`); None: nothing kept.
    last_kept : int or None
        The last frame kept there (frames ``0..last_kept``).
    message : str
        What was detected, without the frame and the cause.
    """

    def __init__(self, message: str, frame: int, cause: str = ""):
        super().__init__(f"frame {frame}: {message}" + (f" (likely cause: {cause})" if cause else ""))
        self.message = message
        self.frame = frame
        self.cause = cause
        self.kept: Path | None = None
        self.last_kept: int | None = None


def shifted(error: EngineDivergence, frames: int, where: str = "") -> EngineDivergence:
    """``error`` from an engine built partway through a run, as the run's: its frame counted from the run's start
    (``frames`` simulated before that engine was built) and ``where`` (words: which engine it was) before its
    message. Raise it ``from error``."""
    return EngineDivergence(f"{where}: {error.message}" if where else error.message, error.frame + frames, error.cause)


class EngineBug(GaspError):
    """An engine raised an exception outside the error contract: a bug in the engine, not the scene.

    Attributes
    ----------
    engine, distribution : str
        The engine and the distribution that provides it.
    where : str
        ``"build"`` (the factory) or ``"frame N"``.
    traceback_file : str
        Where the full traceback was saved (empty if it could not be written).
    """

    def __init__(self, engine: str, distribution: str, where: str, error: BaseException, traceback_file: str = ""):
        self.engine, self.distribution, self.where, self.traceback_file = engine, distribution, where, traceback_file
        saved = f"; traceback saved to {traceback_file}" if traceback_file else ""
        super().__init__(
            f"engine '{engine}' ({distribution or 'unknown distribution'}) failed at {where} with an unexpected "
            f"{type(error).__name__}: {error}. This is a bug in the engine, not in the scene: please report it "
            f"to its authors{saved}")


def save_traceback(e: BaseException, prefix: str, heading: str) -> str:
    """Write ``e``'s full traceback, after the line ``heading``, to a new temporary file named ``prefix...txt``;
    its path, or ``""`` when it cannot be written (a full disk)."""
    import tempfile
    import traceback
    try:
        fd, path = tempfile.mkstemp(prefix=prefix, suffix=".txt")
        with os.fdopen(fd, "w") as f:
            f.write(f"{heading}\n" + "".join(traceback.format_exception(e)))
    except (OSError, RecursionError):
        return ""
    return path


#: The optional packages the core (and gasp_studies) import, by top-level module, and the extra of
#: ``pyproject.toml`` that installs each (Pillow comes with imageio, the render extra).
EXTRA_OF = {"imageio": "render", "imageio_ffmpeg": "render", "numba": "render", "PIL": "render",
            "viser": "view", "gsply": "formats", "imagecodecs": "formats", "zstandard": "formats",
            "skimage": "studies", "matplotlib": "studies", "dask": "studies", "distributed": "studies",
            "tomli_w": "studies", "gasp_studies": "studies", "trimesh": "mesh", "rtree": "mesh",
            "pytest": "test", "hypothesis": "test", "pygltflib": "export", "pxr": "export"}
#: The distribution's name where it differs from the module's.
DISTRIBUTION = {"PIL": "Pillow", "skimage": "scikit-image", "imageio_ffmpeg": "imageio-ffmpeg", "tomli_w": "tomli-w", "pxr": "usd-core"}


def shown_path(folder: Path) -> str:
    """``folder`` as seen from the working directory (``"."`` for it)."""
    try:
        return os.path.relpath(folder)
    except (ValueError, OSError):  # another drive (Windows); a working directory that no longer exists
        return str(folder)


def extra_hint(extra: str) -> str:
    """The ``pip install`` line of the core's optional ``extra`` (``render``, ``view``, ``formats``, ``studies``,
    ``mesh``, ``test``): ``python -m pip install -e ".[render]"`` from a clone (its path as seen from the working
    directory), else ``python -m pip install "gasp[render]"``."""
    root = Path(__file__).resolve().parents[1]
    if (root / "pyproject.toml").is_file():
        return f'python -m pip install -e "{shown_path(root)}[{extra}]"'
    return f'python -m pip install "gasp[{extra}]"'


def missing_module_message(e: ImportError, doing: str, extra: str | None = None) -> str | None:
    """The one-line error for ``e``, an import of an optional package (:data:`EXTRA_OF`) that failed while
    ``doing`` (e.g. ``"'gasp render'"``): the package, and the line that installs ``extra`` (default: the
    package's own, :data:`EXTRA_OF`); None for any other import error (a bug, not a missing extra)."""
    name = getattr(e, "name", None)
    if not name:   # re-raised without it (trimesh's ExceptionWrapper): from the text
        m = re.search(r"No module named '([\w.]+)'|import of ([\w.]+) halted", str(e))
        name = next((g for g in m.groups() if g), "") if m else ""
    top = name.split(".")[0]
    if top not in EXTRA_OF:
        return None
    extra = extra or EXTRA_OF[top]
    return (f"{doing} needs {DISTRIBUTION.get(top, top)}, which is not installed; it comes with the {extra} "
            f"extra: {extra_hint(extra)}")
