"""Warp start-up for :class:`gasp_warp_mpm.engine.WarpMPMEngine`: ``wp.init()`` without the CPU-only noise."""
import warp as wp


def init_warp() -> None:
    """``wp.init()`` without the native "no CUDA driver" warning it prints on machines without a GPU
    (written by Warp's C++ core to the process's stderr, past Python's ``sys.stderr``). Every other line
    it prints is passed on.

    On a CPU run the warning is noise; on a CUDA run the engine refuses in its own one line
    (:func:`start_warp`), so Warp's line beside it is dropped too."""
    import os
    import sys
    import tempfile
    with tempfile.TemporaryFile(mode="w+b") as cap:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(cap.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        cap.seek(0)
        for line in cap.read().decode(errors="replace").splitlines():
            if "CUDA driver" not in line:
                print(line, file=sys.stderr)


def start_warp(dev: str):
    """``wp.init()`` quietly (:func:`init_warp`); the Warp device named by the engine option ``device``.

    Raises EngineError where that device is missing."""
    from gasp_core.seam import EngineError

    from . import ENGINE
    wp.config.log_level = wp.LOG_WARNING  # no start-up banner or module-load lines on stdout
    init_warp()
    if dev.startswith("cuda") and not wp.is_cuda_available():
        raise EngineError(f"engine '{ENGINE}': device '{dev}' requested but Warp finds no CUDA "
                          f"device here (driver missing or no GPU); use device = \"cpu\"")
    try:
        return wp.get_device(dev)
    except Exception as e:  # e.g. "cuda:3" on a one-GPU machine
        raise EngineError(f"engine '{ENGINE}': device '{dev}' is not available: {e}") from e
