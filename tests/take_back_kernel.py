"""A warp kernel that calls warp_mpm's ``take_back.unresolved_fraction`` on given support rows (for
``tests/test_take_back.py``; warp compiles kernels from files only)."""
import numpy as np
import warp as wp

from gasp_warp_mpm.take_back import unresolved_fraction, v64


@wp.kernel
def _fractions(jsums: wp.array2d(dtype=wp.float64), n: wp.array(dtype=v64), h: wp.float64,
               out: wp.array(dtype=wp.float64)):
    s = wp.tid()
    out[s] = unresolved_fraction(jsums, s, n[s], h)


def fractions(rows: np.ndarray, normals: np.ndarray, h: float) -> list[float]:
    """``unresolved_fraction`` of each row of ``rows`` (``gasp_core.mpm.contact.JSUMS`` columns) with its normal."""
    wp.init()
    jsums = wp.array(rows, dtype=wp.float64, device="cpu")
    n = wp.array(normals, dtype=v64, device="cpu")
    out = wp.zeros(len(rows), dtype=wp.float64, device="cpu")
    wp.launch(_fractions, dim=len(rows), inputs=[jsums, n, wp.float64(h), out], device="cpu")
    return out.numpy().tolist()
