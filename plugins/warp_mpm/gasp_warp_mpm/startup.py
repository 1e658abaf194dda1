"""Warp start-up for :class:`gasp_warp_mpm.engine.WarpMPMEngine`: ``wp.init()`` without the CPU-only noise."""
import warp as wp


def init_warp() -> None:
    """``wp.init()`` without the native "no CUDA driver" warning it prints on machines without a GPU
    (written by Warp's C++ core to the process's stderr, past Python's ``sys.stderr``). Every other line
    it prints is passed on.

    On a CPU run the warning is noise; on a CUDA run the engine refuses in its own one line
    (:meth:`gasp_warp_mpm.engine.WarpMPMEngine._start_warp`), so Warp's line beside it is dropped too."""
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
