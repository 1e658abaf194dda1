"""The balance's take-back bound on a patch that is not flat (round 86): :func:`unresolved_fraction`, the kernels'
spelling of ``gasp_core.mpm.take_back.fraction_from_moments`` (its module docstring gives the rule and its figures),
read from a support's row of ``c_jsums`` (``gasp_core.mpm.contact.JSUMS``: ``j``, ``j x``, then ``sum j x x^T`` at
columns 20-25 and ``sum j^2`` at 26). taichi_mpm's ``take_back.py`` spells the same steps.
"""
import warp as wp

from gasp_core.mpm.contact import SKIN
from gasp_core.mpm.take_back import COLLINEAR, PLANE_BOUND

f64 = wp.float64
v64 = wp.types.vector(3, f64)
m64 = wp.types.matrix((3, 3), f64)
#: ``gasp_core.mpm.take_back.PLANE_BOUND`` for the kernels (1: on).
PLANE_RULE = wp.constant(1 if PLANE_BOUND else 0)
SKIN_H = wp.constant(SKIN)
COLLINEAR_TT = wp.constant(COLLINEAR)


@wp.func
def unresolved_fraction(jsums: wp.array2d(dtype=f64), s: int, nb: v64, h: f64):
    # the fraction of the take-back's bound support s keeps: gasp_core.mpm.take_back.fraction_from_moments, step
    # for step (nb the support's mean normal, h the body's point spacing)
    J = jsums[s, 0]
    jj = jsums[s, 26]
    out = f64(1.0)
    if J > f64(0.0) and jj > f64(0.0):
        ne = J * J / jj
        if ne > f64(3.0):
            xb = v64(jsums[s, 1], jsums[s, 2], jsums[s, 3]) / J
            C = m64(jsums[s, 20], jsums[s, 21], jsums[s, 22], jsums[s, 21], jsums[s, 23], jsums[s, 24],
                    jsums[s, 22], jsums[s, 24], jsums[s, 25]) / J - wp.outer(xb, xb)
            a = v64(f64(1.0), f64(0.0), f64(0.0))
            if wp.abs(nb[0]) > f64(0.9):
                a = v64(f64(0.0), f64(1.0), f64(0.0))
            e1 = wp.normalize(wp.cross(nb, a))
            e2 = wp.cross(nb, e1)
            c11 = wp.dot(e1, C * e1)
            c12 = wp.dot(e1, C * e2)
            c22 = wp.dot(e2, C * e2)
            dtt = c11 * c22 - c12 * c12
            out = f64(0.0)   # collinear: an edge
            if dtt > f64(COLLINEAR_TT) * (c11 + c22) * (c11 + c22):
                rho2 = wp.max(wp.determinant(C) / dtt, f64(0.0)) * ne / (ne - f64(3.0))
                out = wp.min(f64(1.0), wp.sqrt(f64(12.0) * rho2) / (f64(SKIN_H) * h))
    return out
