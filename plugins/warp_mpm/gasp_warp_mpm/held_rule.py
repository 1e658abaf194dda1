"""The brittle held rule (docs/fracture.md, "The held region", round 32): how a ``fixed_region`` and a box impulse of
``mode = "set"`` hold the material of a brittle body, as Warp functions and kernels per scalar type
(:mod:`gasp_warp_mpm.precision`); taichi_mpm's ``GridUpdate.held_rule``, the same three parts:

- a set box's brittle point near its face scatters the stress of its held damage (:func:`build_held_tau`), never
  softened on the way;
- its velocity gradient is the grid's gathered at its mirror image across the box's face (``image_C``; the ghosts'
  where the image's stencil has a node without mass). A fixed region's held points keep the rule before (with these
  two parts there a T rod hung by its head diverged, docs/fracture.md);
- the free node within ``SET_FACE_CELLS`` outside a set box's face holds the face's linear velocity
  (:func:`build_hold_set_faces`).

A set box's points move with the grid, as any body's: held at ``v_set`` (and rigid deeper in) they stored a strain
their positions did not show, and the conformance scene ``brittle_below_strength`` failed (docs/fracture.md).

The switch is :attr:`HeldRule.held_rule` (a kernel argument: False runs the rule of before, the tension family's
catch, ``tests/test_tension_family.py``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm import grid_tables
from gasp_core.mpm.grid_tables import (COL_POSE, FT_POSES, IM_A, IM_B, IM_MODE, IM_SHAPE, IMPULSE_ADD,
                                       IMPULSE_BOX, IMPULSE_ROW)
from gasp_core.mpm.materials import BRITTLE
from gasp_core.mpm.points import HELD_STRAINED, SET_FACE_CELLS

from .constitutive import build_decompositions
from .fields import build_field_reads
from .mid_stress import MID_BIT
from .trapezoid import TRAP_BIT, TrapezoidStress
from .forces import build_constrain, build_extras_struct, build_set_velocity
from .precision import MODULE_OPTIONS, build_types
from .stencil import build_gather, build_stencil


class HeldRule(TrapezoidStress):
    """The engine's switch of the brittle held rule (a mixin of :class:`gasp_warp_mpm.engine.WarpMPMEngine`)."""

    #: True: the brittle held rule of round 32 (the module's docstring); False: the rule before it (the catch of
    #: ``tests/test_tension_family.py``). Read when the launches are recorded.
    held_rule = True
    #: True: a free brittle point's softening range is scaled by its crack band weight (round 33; ``constitutive``'s
    #: ``band_sf``); False: one ``s_f`` for every point, as before (the catch of ``tests/test_tension_family.py``).
    weighted_band = True
    #: True: with :attr:`weighted_band`, a free brittle point's band is the cell's projection on its crack's normal
    #: (round 34; ``constitutive``'s ``band_sf``, ``gasp_core.mpm.materials.band_projection``); False (the default):
    #: the band ``dx`` at every angle. Off: on the oblique dog-bones it brings the damage's dissipation to G_f but the
    #: must-show's work to separate to -28 % at 45 deg (docs/fracture.md "Oblique specimens (round 34)").
    oblique_band = False

    def held_rule_flag(self) -> int:
        """The kernels' ``rule`` argument: where a body is brittle, bit 0 the held rule (:attr:`held_rule`),
        bit 1 the crack band weight (:attr:`weighted_band`), bit 2 the band's projection (:attr:`oblique_band`, with
        bit 1 only); for every body, bit 3 the midpoint stress (the option ``stress_at = "mid"``, mid_stress.py), bit 4
        the trapezoidal one (``"trapezoid"``, trapezoid.py)."""
        brittle = bool((self.mat_kind.numpy() == BRITTLE).any())
        weighted = bool(self.weighted_band) and brittle
        return (int(bool(self.held_rule) and brittle) + 2 * int(weighted) + 4 * int(weighted and self.oblique_band)
                + MID_BIT * int(self.config.stress_at == "mid") + TRAP_BIT * int(self.config.stress_at == "trapezoid"))


@functools.cache
def build_held_tau(Ft):
    """``held_tau(F, mu, lam, d)``: the brittle Kirchhoff stress (Pa, ``mat33``) of a held point at its held damage
    ``d``: the undamaged Hencky principal stresses ``s_i = 2 mu eps_i + lam tr(eps)`` of ``F``, the tensile ones scaled
    by ``1 - d`` (the return mapping's ``brittle_return`` with ``d`` not raised: the point does not soften on its own
    strain; taichi_mpm's ``brittle_tau`` with ``f_t = s_f``)."""
    vec3, vec4, mat33 = build_types(Ft)
    svd = build_decompositions(Ft)[2]

    @wp.func
    def held_tau(Fp: mat33, mu: Ft, lam: Ft, d: Ft):
        U, sig, V = svd(Fp)
        eps = vec3(wp.log(wp.max(sig[0], Ft(1e-4))), wp.log(wp.max(sig[1], Ft(1e-4))),
                   wp.log(wp.max(sig[2], Ft(1e-4))))
        s = Ft(2.0) * mu * eps + vec3(lam * (eps[0] + eps[1] + eps[2]))
        g = vec3(Ft(1.0))
        for i in range(3):
            if s[i] > Ft(0.0):
                g[i] = Ft(1.0) - d
        return U * wp.diag(wp.cw_mul(g, s)) * wp.transpose(U)

    return held_tau


@functools.cache
def build_image_gather(Ft):
    """``image_gather(grid_v, grid_dv, grid_m, off, W, base, n_grid, a, f, lo, inv_dx, vs)``: ``(v, B)`` as
    ``stencil.build_gather``'s over the image's 27 nodes from node ``base`` (``wp.vec3i``), each node ``J`` by its share
    against ``K``, the node nearest its mirror image across the face at ``f`` (m) along axis ``a`` (the ghost that takes
    it, ``held.build_mirror``'s ``image_share``): ``vs + min(1, m_J / m_K) (v_J - vs)``, ``vs`` the set box's velocity
    (m/s), ``v_J`` where ``K`` has no mass (docs/fracture.md "Round 40"; taichi_mpm's ``Forces.image_node_v``)."""
    vec3, vec4, mat33 = build_types(Ft)
    field_node_v = build_field_reads(Ft)[1]

    @wp.func
    def image_gather(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft),
                     off: int, W: mat33, base: wp.vec3i, n_grid: int, a: int, f: Ft, lo: vec3, inv_dx: Ft, vs: vec3):
        v = vec3(Ft(0.0))
        B = mat33(Ft(0.0))
        stride = int(1)
        if a == 0:
            stride = n_grid * n_grid
        elif a == 1:
            stride = n_grid
        for q in range(27):
            ijk = wp.vec3i(q / 9, (q / 3) % 3, q % 3)
            J = base + ijk
            node = (J[0] * n_grid + J[1]) * n_grid + J[2]
            g = field_node_v(grid_v, grid_dv, off, node)
            k = int(wp.round(Ft(2.0) * (f - lo[a]) * inv_dx - Ft(J[a])))
            k = wp.min(wp.max(k, 0), n_grid - 1)
            mk = grid_m[node + (k - J[a]) * stride]
            if mk > Ft(0.0):
                g = vs + wp.min(Ft(1.0), grid_m[node] / mk) * (g - vs)
            wg = (W[ijk[0], 0] * W[ijk[1], 1] * W[ijk[2], 2]) * g
            v = v + wg
            B = B + wp.outer(wg, vec3(Ft(ijk[0]), Ft(ijk[1]), Ft(ijk[2])))
        return v, B

    return image_gather


@functools.cache
def build_image_C(Ft):
    """``image_C(C, a, code, X, ex, fixed_lo, fixed_hi, grid_v, grid_dv,
    grid_m, off, lo, inv_dx, n_grid)``: the velocity gradient (1/s, ``mat33``) of a brittle point at ``X`` (m)
    near a held box's face of normal axis ``a`` (``held.build_image_flip``'s ``held_axis``): the grid's gradient
    gathered at its mirror image ``X'`` across the nearest face of the box that holds it (a fixed region for ``code
    >= HELD_STRAINED``, a set box for ``code`` 0), as the ghost field's, ``grad v(X') D``, so its ``F`` follows the
    image's strain for any field; ``C`` where no box holds it, ``X'`` is off the grid or a node of its stencil has no
    mass (``grid_m``: no material there to follow, as past a T rod's head). taichi_mpm's ``GridUpdate.image_C``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    from .held import build_image_flip   # held.py's P2G rule imports this module
    held_axis, image_flip, set_box_at = build_image_flip(Ft)
    in_grid, weights = build_stencil(Ft)
    gather, image_gather = build_gather(Ft), build_image_gather(Ft)
    set_box_row = build_set_box_row(Ft)
    along_matrix = build_constrain(Ft)[1]
    by_mass = int(bool(grid_tables.IMAGE_BY_MASS))   # read when the kernels are built

    @wp.func
    def image_C(Cp: mat33, a: int, code: int, X: vec3, ex: Extras, fixed_lo: wp.array(dtype=vec3),
                fixed_hi: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                grid_m: wp.array(dtype=Ft), off: int, lo: vec3, inv_dx: Ft, n_grid: int):
        f = X[a]
        best = Ft(1e30)
        if code >= HELD_STRAINED:
            for b in range(fixed_lo.shape[0]):
                flo = fixed_lo[b]
                fhi = fixed_hi[b]
                if (X[0] >= flo[0] and X[1] >= flo[1] and X[2] >= flo[2] and X[0] <= fhi[0] and X[1] <= fhi[1]
                        and X[2] <= fhi[2]):
                    if X[a] - flo[a] < best:
                        best = X[a] - flo[a]
                        f = flo[a]
                    if fhi[a] - X[a] < best:
                        best = fhi[a] - X[a]
                        f = fhi[a]
        qs = int(-1)   # the set box (its image nodes by mass: image_gather)
        if code == 0:
            q = set_box_at(X, ex)
            if q >= 0:
                c = ex.imps[q * IMPULSE_ROW + IM_A + a]
                h = ex.imps[q * IMPULSE_ROW + IM_B + a]
                if X[a] - c < best:
                    best = X[a] - c
                    f = c
                    qs = q
                if h - X[a] < best:
                    best = h - X[a]
                    f = h
                    qs = q
        out = Cp
        if best < Ft(1e29):
            Xi = vec3(X[0], X[1], X[2])
            Xi[a] = Ft(2.0) * f - X[a]
            G = (Xi - lo) * inv_dx
            if in_grid(G, n_grid):
                b0 = wp.floor(G[0] - Ft(0.5))
                b1 = wp.floor(G[1] - Ft(0.5))
                b2 = wp.floor(G[2] - Ft(0.5))
                fx = G - vec3(b0, b1, b2)
                W = weights(fx)
                idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
                v, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)
                if by_mass != 0 and qs >= 0:
                    c_, b_, vs, on_ = set_box_row(ex, qs)
                    v, B = image_gather(grid_v, grid_dv, grid_m, off, W, wp.vec3i(int(b0), int(b1), int(b2)),
                                        n_grid, a, f, lo, inv_dx, vs)
                full = int(1)   # the image's stencil all in material (else the ghosts' C: no image to follow)
                for q in range(27):
                    if grid_m[idx0 + ((q / 9) * n_grid + (q / 3) % 3) * n_grid + q % 3] <= Ft(0.0):
                        full = 0
                if full != 0:
                    out = ((Ft(4.0) * inv_dx) * (B - wp.outer(v, fx))) * image_flip(a)
        return along_matrix(ex, qs, Cp, out)   # constrain = "along": the image's rows along the pull alone

    return image_C


@functools.cache
def build_held_g2p(Ft):
    """``held_g2p(C, code, X, ex, fixed_lo, fixed_hi, grid_v, grid_dv, grid_m, off, lo, inv_dx, dx, n_grid)``:
    G2P's ``C`` (1/s, ``mat33``) of a brittle point under the rule (``code`` its hold, ``held_codes``): near a set
    box's face its mirror image's gradient (``image_C``, :func:`build_image_C`; a fixed region's held points keep the
    ghosts' gradient: with the image's a T rod hung by its head diverged), else ``C``. taichi_mpm's ``g2p_point``
    under ``held_rule``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    from .held import build_image_flip   # held.py's P2G rule imports this module
    held_axis, image_flip, set_box_at = build_image_flip(Ft)
    image_C = build_image_C(Ft)

    @wp.func
    def held_g2p(Cn: mat33, code: int, X: vec3, ex: Extras, fixed_lo: wp.array(dtype=vec3),
                 fixed_hi: wp.array(dtype=vec3), grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                 grid_m: wp.array(dtype=Ft), off: int, lo: vec3, inv_dx: Ft, dx: Ft, n_grid: int):
        a = held_axis(code, X, dx, ex)
        C_out = Cn
        if a >= 0 and code == 0:   # a set box's (a fixed region's held points: the ghosts' gradient, as before)
            C_out = image_C(Cn, a, code, X, ex, fixed_lo, fixed_hi, grid_v, grid_dv, grid_m, off, lo, inv_dx,
                            n_grid)
        return C_out

    return held_g2p


@functools.cache
def build_set_box_row(Ft):
    """``set_box_row(ex, q) -> (c, b, dv, on)``: impulse ``q``'s box corners, the velocity it imposes now (its ramp
    factor times its ``velocity_change``, ``forces.build_set_velocity``) and whether it is a set box holding its nodes
    at this substep (a box whose mode is not ``add``, its weight above 0); read by :func:`build_hold_set_faces` and
    ``held.build_mirror``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    set_velocity = build_set_velocity(Ft)

    @wp.func
    def set_box_row(ex: Extras, q: int):
        r = q * IMPULSE_ROW
        c = vec3(ex.imps[r + IM_A], ex.imps[r + IM_A + 1], ex.imps[r + IM_A + 2])
        b = vec3(ex.imps[r + IM_B], ex.imps[r + IM_B + 1], ex.imps[r + IM_B + 2])
        w = ex.tab[ex.step[0] * ex.width + FT_POSES + COL_POSE * ex.n_col + q]
        dv = vec3(Ft(0.0))
        on = int(0)
        if ex.imps[r + IM_SHAPE] == Ft(IMPULSE_BOX) and ex.imps[r + IM_MODE] != Ft(IMPULSE_ADD) and w > Ft(0.0):
            on = 1
            dv = set_velocity(ex, q, w)
        return c, b, dv, on

    return set_box_row


@functools.cache
def build_hold_set_faces(Ft):
    """``hold_set_faces``: the kernel over the grid update's box (round 65, ``grid_box.py``), after the grid update and before the held boxes' ghosts
    (``held.build_mirror``), where a set box holds a brittle body: a node with mass within ``SET_FACE_CELLS`` outside a
    set box's face (along its normal, inside its extent along the face) whose next node outward has mass takes
    ``(v_set + s v_out) / (1 + s)``, ``s`` its distance to the face in cells, ``v_out`` that node's velocity, so the
    grid's linear velocity meets ``v_set`` on the face for any field. taichi_mpm's ``Forces.hold_set_faces``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    set_box_row = build_set_box_row(Ft)
    constrain = build_constrain(Ft)[0]
    from .field_nodes import build_sweep
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def hold_set_faces(grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft), lo: vec3, dx: Ft, inv_dx: Ft,
                       n_grid: int, ex: Extras, box: wp.array(dtype=wp.int32), threads: int, along: int):
        n = box_units(box, along)   # round 65: the grid update's box (grid_box.py), not the whole grid
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    if grid_m[node] > Ft(0.0):
                        I = wp.vec3i(node / (n_grid * n_grid), (node / n_grid) % n_grid, node % n_grid)
                        X = lo + dx * vec3(Ft(I[0]), Ft(I[1]), Ft(I[2]))
                        for qi in range(ex.n_imp):
                            c, b, dv, on = set_box_row(ex, qi)
                            if on != 0:
                                for d in range(3):
                                    lat = int(1)
                                    for e in range(3):
                                        if e != d and (X[e] < c[e] or X[e] > b[e]):
                                            lat = 0
                                    stride = int(1)
                                    if d == 0:
                                        stride = n_grid * n_grid
                                    elif d == 1:
                                        stride = n_grid
                                    sl = (c[d] - X[d]) * inv_dx
                                    sh = (X[d] - b[d]) * inv_dx
                                    if lat != 0 and sl > Ft(0.0) and sl < Ft(SET_FACE_CELLS) and I[d] >= 1:
                                        if grid_m[node - stride] > Ft(0.0):
                                            grid_v[node] = constrain(ex, qi, grid_v[node],
                                                                     (dv + sl * grid_v[node - stride]) / (Ft(1.0) + sl))
                                    if lat != 0 and sh > Ft(0.0) and sh < Ft(SET_FACE_CELLS) and I[d] < n_grid - 1:
                                        if grid_m[node + stride] > Ft(0.0):
                                            grid_v[node] = constrain(ex, qi, grid_v[node],
                                                                     (dv + sh * grid_v[node + stride]) / (Ft(1.0) + sh))

    return hold_set_faces


def hold_set_faces_launches(eng, Ft, ex) -> list:
    """The recorded launch of :func:`build_hold_set_faces`'s kernel, where a set box impulse and a brittle body meet
    the switch (:meth:`HeldRule.held_rule_flag`); else none."""
    from .held import count_set_boxes
    if not count_set_boxes(eng.setup) or not eng.held_rule_flag() % 2:
        return []
    from .grid_box import grid_sweep
    lo_v = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    sweep = grid_sweep(eng)   # round 65: over the grid update's box (grid_box.py)
    return [wp.launch(build_hold_set_faces(Ft), dim=sweep[1], device=eng.device, record_cmd=True, inputs=[
        eng.grid_v, eng.grid_m, lo_v, Ft(eng.dx), Ft(eng.inv_dx), eng.n_grid, ex, *sweep])]
