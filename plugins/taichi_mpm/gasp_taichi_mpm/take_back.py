"""The balance's take-back bound on a patch that is not flat (round 86): :func:`unresolved_fraction`, the kernels'
spelling of ``gasp_core.mpm.take_back.fraction_from_moments`` (its module docstring gives the rule and its figures),
read from a support's row of ``c_jsums`` (``gasp_core.mpm.contact.JSUMS``: ``j``, ``j x``, then ``sum j x x^T`` at
columns 20-25 and ``sum j^2`` at 26). warp_mpm's ``take_back.py`` spells the same steps.
"""
import taichi as ti

from gasp_core.mpm.contact import SKIN
from gasp_core.mpm.take_back import COLLINEAR, PLANE_BOUND

#: Whether the kernels compile the rule (``gasp_core.mpm.take_back.PLANE_BOUND``).
PLANE_RULE = bool(PLANE_BOUND)


@ti.func
def unresolved_fraction(jsums: ti.template(), s, nb, h):
    """The fraction of the take-back's bound support s keeps (``nb`` its mean normal, ``h`` the body's point
    spacing, m; float64)."""
    J = jsums[s, 0]
    jj = jsums[s, 26]
    out = ti.cast(1.0, ti.f64)
    if J > 0.0 and jj > 0.0:
        ne = J * J / jj
        if ne > 3.0:
            xb = ti.Vector([jsums[s, 1], jsums[s, 2], jsums[s, 3]], ti.f64) / J
            C = ti.Matrix([[jsums[s, 20], jsums[s, 21], jsums[s, 22]], [jsums[s, 21], jsums[s, 23], jsums[s, 24]],
                           [jsums[s, 22], jsums[s, 24], jsums[s, 25]]], ti.f64) / J - xb.outer_product(xb)
            a = ti.Vector([1.0, 0.0, 0.0], ti.f64)
            if ti.abs(nb[0]) > 0.9:
                a = ti.Vector([0.0, 1.0, 0.0], ti.f64)
            e1 = nb.cross(a).normalized()
            e2 = nb.cross(e1)
            c11 = e1.dot(C @ e1)
            c12 = e1.dot(C @ e2)
            c22 = e2.dot(C @ e2)
            dtt = c11 * c22 - c12 * c12
            out = 0.0   # collinear: an edge
            if dtt > COLLINEAR * (c11 + c22) * (c11 + c22):
                rho2 = ti.max(C.determinant() / dtt, 0.0) * ne / (ne - 3.0)
                out = ti.min(1.0, ti.sqrt(12.0 * rho2) / (SKIN * h))
    return out
