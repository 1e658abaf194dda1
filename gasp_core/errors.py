"""The errors of GASP's error contract (``docs/writing_an_engine.md``, "Errors").

========================  ==============================================  ==========
raised                    meaning                                          CLI exit
========================  ==============================================  ==========
:class:`SceneError`       the input is wrong or unsupported (scene key,    2
                          file, a material or feature the engine lacks)
:class:`EngineError`      the engine cannot run here (package missing,     2
                          device absent, closed engine)
:class:`EngineDivergence` the simulation blew up (NaN, points left the     3
                          domain); names the frame and the likely cause
:class:`EngineBug`        anything else an engine raised: a bug in the     4
                          engine, reported with its traceback saved
========================  ==============================================  ==========
"""
from __future__ import annotations


class GaspError(Exception):
    """Base class of every error GASP raises on purpose."""


class SceneError(GaspError, ValueError):
    """A scene file or its input is wrong; the message names the key, field or file."""


class EngineError(GaspError, RuntimeError):
    """An engine cannot run the scene (missing capability, unavailable device)."""


class EngineDivergence(GaspError, RuntimeError):
    """The simulation blew up: non-finite values or points leaving the domain.

    Attributes
    ----------
    frame : int
        The frame (1-based, the first frame after the initial state) at which it was detected.
    cause : str
        The likely cause, in words (time step too large, stiffness too high, ...).
    """

    def __init__(self, message: str, frame: int, cause: str = ""):
        super().__init__(f"frame {frame}: {message}" + (f" (likely cause: {cause})" if cause else ""))
        self.frame = frame
        self.cause = cause


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
