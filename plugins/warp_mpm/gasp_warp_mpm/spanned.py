"""The passive gather's pseudo-inverse over the directions the material spans (round 38), with round 39's fast path:
``M``'s plain inverse where Gershgorin's bound proves all three directions spanned. taichi_mpm's
``Transfers.spanned_inverse`` and ``Transfers.spans_all`` spell the same steps."""
import functools

import warp as wp

from .constitutive import build_sym_eig
from .precision import build_types


#: The spanned gather's inverse by ``M``'s plain inverse where Gershgorin's bound proves all three directions spanned
#: (``spans_all``), the Jacobi only elsewhere (round 39, taichi_mpm's ``Transfers.PASSIVE_FAST_INVERSE``); False:
#: always the Jacobi. Read when the function is built (clear :func:`build_spanned_inverse`'s cache after a change).
PASSIVE_FAST_INVERSE = True


@functools.cache
def build_spans_all(Ft):
    """``spans_all(M, wsum, span_mass) -> bool``, scalar type ``Ft``: whether all three directions of the symmetric
    moment ``M`` are provably spanned, ``lam_min wsum > span_mass``, by Gershgorin's lower bound on its smallest
    eigenvalue, ``min_i (M_ii - sum_{j != i} |M_ij|)`` (Golub & Van Loan, "Matrix Computations", Thm. 7.2.1);
    taichi_mpm's ``Transfers.spans_all`` (round 39)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def spans_all(M: mat33, wsum: Ft, span_mass: Ft):
        lb = M[0, 0] - wp.abs(M[0, 1]) - wp.abs(M[0, 2])
        lb = wp.min(lb, M[1, 1] - wp.abs(M[1, 0]) - wp.abs(M[1, 2]))
        lb = wp.min(lb, M[2, 2] - wp.abs(M[2, 0]) - wp.abs(M[2, 1]))
        return lb * wsum > span_mass

    return spans_all


@functools.cache
def build_spanned_inverse(Ft):
    """``spanned_inverse(M, wsum, span_mass) -> M^+``, scalar type ``Ft``: the pseudo-inverse of the symmetric
    moment ``M`` (3x3, cells^2 per unit weight; ``wsum`` the weights' sum, kg) over the eigen-directions the material
    spans, ``lam wsum > span_mass`` (kg cells^2, ``grid_tables.passive_span_mass``): ``sum_k V_k V_k^T / lam_k``
    (cyclic Jacobi, ``constitutive.build_sym_eig``); taichi_mpm's ``Transfers.spanned_inverse`` (round 38). With
    :data:`PASSIVE_FAST_INVERSE`, where :func:`build_spans_all`'s bound proves all three spanned, ``M``'s plain
    inverse, the same ``M^+`` (round 39)."""
    vec3, vec4, mat33 = build_types(Ft)
    sym_eig = build_sym_eig(Ft)
    spans_all = build_spans_all(Ft)
    fast = 1 if PASSIVE_FAST_INVERSE else 0

    @wp.func
    def spanned_inverse(M: mat33, wsum: Ft, span_mass: Ft):
        Minv = mat33()
        if fast == 1 and spans_all(M, wsum, span_mass):
            Minv = wp.inverse(M)
        else:
            V, lam = sym_eig(M)
            for k in range(3):
                if lam[k] * wsum > span_mass:
                    e = vec3(V[0, k], V[1, k], V[2, k])
                    Minv = Minv + wp.outer(e, e) / lam[k]
        return Minv

    return spanned_inverse
