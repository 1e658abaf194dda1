"""The balance's torque take-back, bounded by how far its patch lies from a plane (round 86, ``docs/contact.md``
"Round 86: the take-back where the patch is not flat").

The particle contact's balance (issue 38, :data:`gasp_core.mpm.contact.TORQUE_REACH`) takes back a body's contact
torque up to ``J TORQUE_REACH REACH h``: the torque of a centre of pressure that a handful of irregular points cannot
resolve. A support's pushed points sample the contact surface. Where they lie in one plane (a flat face of a fill
lattice, however tilted or leaning), the penalty's impulses are affine in position, and their centre is the
contact's own resolved centre of pressure; a torque there is the body's. Taking it back held a tall jelly block
upright on 30 degrees, which explicit finite elements topple (round 85, ``benchmarks/studies/tall85.py``), and halved
its elastic lean. Where the points do not lie in a plane (a curved or jittered surface), the penalty loads whichever
points happen to lie lowest, and the torque is the sampling's.

The measure is ``rho``, the impulse-weighted rms departure of the pushed points' heights along the support's normal
``n`` from their best plane. It is the residual of the regression of height on the tangent coordinates,
``rho^2 = det C / det C_tt``, with ``C`` the impulse-weighted covariance of the points' positions and ``C_tt`` its
block in the tangent plane. It takes the small-sample correction ``n_eff / (n_eff - 3)`` of a three-parameter fit,
with ``n_eff = J^2 / sum j^2``. A patch whose heights spread uniformly over the contact skin ``s = SKIN h`` about any
plane has ``rho = s / sqrt(12)``: it resolves nothing. The bound is scaled by

    f = min(1, sqrt(12) rho / (SKIN h)),

with ``f = 1`` where ``n_eff <= 3`` (three points always lie in a plane) and ``f = 0`` on collinear points (an edge,
about which the body pivots). Measured (round 86, ``docs/contact.md``, ``benchmarks/studies/patch_plane86.py``): a
flat base ``rho`` 0.001 h (the tall block; f 0.007); the conformance suite's jittered ball at rest 0.024-0.045 h
with ``n_eff`` 5-9 (f 0.26-0.39); its lattice ball at impact 0.003-0.009 h (f 0.03-0.07).
"""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.contact import SKIN

#: Round 86: the take-back's bound scaled by :func:`unresolved_fraction` (false: the bound of rounds 38-85, the
#: whole ``J TORQUE_REACH REACH h`` on every patch). The engines' kernels read it when they compile.
PLANE_BOUND = True
#: Below this ``det C_tt / (tr C_tt)^2`` the pushed points are collinear: an edge, ``f = 0``.
COLLINEAR = 1.0e-12
#: Columns of ``gasp_core.mpm.contact.JSUMS`` that this rule reads past the box: ``sum j x x^T`` (six) and
#: ``sum j^2``.
PLANE_COLUMNS = ("jxx", "jxy", "jxz", "jyy", "jyz", "jzz", "jj")


def unresolved_fraction(j: np.ndarray, x: np.ndarray, n: np.ndarray, h: float) -> float:
    """The fraction ``f`` of the take-back's bound a support keeps (module docstring; the kernels' reference).

    Parameters
    ----------
    j : ndarray, shape (k,)
        The pushed points' normal impulses (kg m/s, >= 0).
    x : ndarray, shape (k, 3)
        Their positions (m).
    n : ndarray, shape (3,)
        The support's mean contact normal (unit).
    h : float
        The body's point spacing (m; ``REACH h`` is the engines' ``reach``).

    Returns
    -------
    float
        In [0, 1]; 1 with no impulse.
    """
    j = np.asarray(j, np.float64)
    x = np.asarray(x, np.float64).reshape(-1, 3)
    J, jj = float(j.sum()), float((j * j).sum())
    if J <= 0.0 or jj <= 0.0:
        return 1.0
    xb = j @ x / J
    second = np.einsum("i,ij,ik->jk", j, x, x) / J
    return fraction_from_moments(J, jj, second - np.outer(xb, xb), np.asarray(n, np.float64), h)


def fraction_from_moments(J: float, jj: float, C: np.ndarray, n: np.ndarray, h: float) -> float:
    """:func:`unresolved_fraction` from a support's sums: ``J``, ``sum j^2``, the impulses' covariance ``C`` about
    their centre (m^2, 3 x 3), the normal ``n`` and the spacing ``h`` (m): the kernels' steps."""
    ne = J * J / jj
    if ne <= 3.0:
        return 1.0
    rho2 = plane_departure(C, n)
    if rho2 is None:
        return 0.0
    return float(min(1.0, np.sqrt(12.0 * rho2 * ne / (ne - 3.0)) / (SKIN * h)))


def plane_departure(C: np.ndarray, n: np.ndarray) -> float | None:
    """``rho^2`` (m^2), the mean square departure of heights along the unit normal ``n`` from their best plane, of
    points with covariance ``C`` (m^2, 3 x 3): ``det C / det C_tt``, without the small-sample correction; None where
    the points are collinear in the tangent plane (``det C_tt <= COLLINEAR (tr C_tt)^2``)."""
    a = np.array([0.0, 1.0, 0.0]) if abs(n[0]) > 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    c11, c12, c22 = e1 @ C @ e1, e1 @ C @ e2, e2 @ C @ e2
    dtt = c11 * c22 - c12 * c12
    if dtt <= COLLINEAR * (c11 + c22) ** 2:
        return None
    return max(float(np.linalg.det(C)) / dtt, 0.0)
