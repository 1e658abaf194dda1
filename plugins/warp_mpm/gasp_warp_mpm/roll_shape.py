"""Round 72 (``gasp_core.mpm.roll_contact``'s ``cylinder_patch``; ``docs/rigid.md`` "Round 72: a cylinder rolling on a
soft body"): the exact shapes of the option ``roll_contact`` besides the sphere (``point_grid.pg_mark``'s): a solid
capped cylinder's distance to a soft point's patch, in float64, one thread a point (no loop over points).

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import warp as wp

from gasp_core.mpm.roll_contact import DOMAIN_BISECT

from .rigid_pairs import mat33d, vec3d

#: The floats of a slot's cylinder in ``pg_cyl``: radius, half-length, the axis in the body's rest frame.
NC = wp.constant(5)
#: Round 83: :func:`domain_near`'s bisections (``gasp_core.mpm.roll_contact.DOMAIN_BISECT``, read at import).
BISECT = wp.constant(int(DOMAIN_BISECT))


@wp.func
def patch_tangents(m: vec3d):
    """``(t1, t2)``: two unit tangents across a soft point's patch of outward normal ``m`` (unit, nonzero): the patch
    frame of ``point_grid``'s lattice, sphere and cylinder reads (round 67's)."""
    t1 = wp.cross(m, vec3d(wp.float64(1.0), wp.float64(0.0), wp.float64(0.0)))
    if wp.abs(m[0]) > wp.float64(0.9):
        t1 = wp.cross(m, vec3d(wp.float64(0.0), wp.float64(1.0), wp.float64(0.0)))
    t1 = wp.normalize(t1)
    return t1, wp.cross(m, t1)


@wp.func
def cyl_clamp(a: wp.float64, lo: wp.float64, hi: wp.float64):
    return wp.min(wp.max(a, lo), hi)


@wp.func
def cyl_patch(xp: vec3d, m: vec3d, patch: wp.float64, c: vec3d, rot: mat33d, cyl: wp.array(dtype=wp.float64),
              s: int, sweeps: int):
    """``(phi, n, q)``: the patch centred on ``xp`` (normal ``m``, half-size ``patch``) against slot ``s``'s cylinder
    (``cyl``: its radius, half-length and rest-frame axis; centre ``c``, rotation ``rot``): the patch's point ``xp +
    q`` nearest the axis's line (``sweeps`` sweeps of coordinate descent over the square), the signed distance and
    outward normal there (``roll_contact.cylinder_patch``)."""
    o = NC * s
    R = cyl[o]
    h = cyl[o + 1]
    e = wp.normalize(rot * vec3d(cyl[o + 2], cyl[o + 3], cyl[o + 4]))
    d = xp - c
    q = vec3d(wp.float64(0.0))
    if wp.length(m) > wp.float64(0.0) and patch > wp.float64(0.0):
        t1, t2 = patch_tangents(m)
        a1 = t1 - wp.dot(t1, e) * e
        a2 = t2 - wp.dot(t2, e) * e
        b = d - wp.dot(d, e) * e
        u = wp.float64(0.0)
        v = wp.float64(0.0)
        for _ in range(sweeps):
            if wp.dot(a1, a1) > wp.float64(1.0e-12):
                u = cyl_clamp(-wp.dot(a1, b + v * a2) / wp.dot(a1, a1), -patch, patch)
            if wp.dot(a2, a2) > wp.float64(1.0e-12):
                v = cyl_clamp(-wp.dot(a2, b + u * a1) / wp.dot(a2, a2), -patch, patch)
        q = u * t1 + v * t2
    phi, n = cyl_at(d + q, e, R, h)
    return phi, n, q


@wp.func
def cyl_at(y: vec3d, e: vec3d, R: wp.float64, h: wp.float64):
    """``(phi, n)``: the solid capped cylinder's signed distance and outward normal at ``y`` (the point less its
    centre; unit axis ``e``, radius ``R``, half-length ``h``; ``roll_contact.cylinder_at``)."""
    z = wp.dot(y, e)
    rr = y - z * e
    rho = wp.length(rr)
    dr = rho - R
    dz = wp.abs(z) - h
    er = rr / wp.max(rho, wp.float64(1.0e-300))
    ez = e
    if z < wp.float64(0.0):
        ez = -e
    phi = dz
    n = ez
    if dr > wp.float64(0.0) and dz > wp.float64(0.0):
        phi = wp.sqrt(dr * dr + dz * dz)
        n = (dr * er + dz * ez) / phi
    elif dr >= dz:
        phi = dr
        n = er
    return phi, n


@wp.func
def domain_near(xp: vec3d, a: wp.float64, c: vec3d, e: vec3d, bisect: int):
    """Round 83 (``gasp_core.mpm.roll_contact.domain_point``, the reference): the offset of the point of a soft
    point's domain (the cube ``xp + u``, ``|u_k| <= a`` on the fill's axes) nearest the point ``c`` (``e`` zero: the
    clamp) or the line through ``c`` along the unit ``e`` (``bisect`` bisections of the convex distance's derivative
    along the line)."""
    b = c - xp
    if wp.length(e) > wp.float64(0.0):
        t0 = -wp.dot(b, e)
        h = wp.sqrt(wp.float64(3.0)) * a
        lo = t0 - h
        hi = t0 + h
        for _ in range(bisect):
            t = wp.float64(0.5) * (lo + hi)
            l = b + t * e
            k = vec3d(cyl_clamp(l[0], -a, a), cyl_clamp(l[1], -a, a), cyl_clamp(l[2], -a, a))
            if wp.dot(l - k, e) < wp.float64(0.0):
                lo = t
            else:
                hi = t
        b = b + wp.float64(0.5) * (lo + hi) * e
    return vec3d(cyl_clamp(b[0], -a, a), cyl_clamp(b[1], -a, a), cyl_clamp(b[2], -a, a))


@wp.func
def cyl_domain(xp: vec3d, patch: wp.float64, c: vec3d, rot: mat33d, cyl: wp.array(dtype=wp.float64),
               s: int, sweeps: int):
    """Round 83: :func:`cyl_patch` with the point read as its domain (:func:`domain_near`) for the patch."""
    o = NC * s
    e = wp.normalize(rot * vec3d(cyl[o + 2], cyl[o + 3], cyl[o + 4]))
    q = domain_near(xp, patch, c, e, BISECT)
    phi, n = cyl_at(xp - c + q, e, cyl[o], cyl[o + 1])
    return phi, n, q


@wp.func
def cyl_rot(rot: mat33d, turn: int):
    """The body's rotation (``turn`` 0, a broken variant: its transpose, the axis turned the wrong way)."""
    r = rot
    if turn == 0:
        r = wp.transpose(rot)
    return r


@wp.func
def cyl_near(xp: vec3d, c: vec3d, cyl: wp.array(dtype=wp.float64), s: int, skin: wp.float64, patch: wp.float64):
    """Whether slot ``s`` is a cylinder (radius > 0) whose bounding sphere, with the skin and a cell (4 patches), holds
    the point ``xp``."""
    o = NC * s
    R = cyl[o]
    h = cyl[o + 1]
    return R > wp.float64(0.0) and wp.length(xp - c) < wp.sqrt(R * R + h * h) + skin + wp.float64(6.0) * patch


@wp.func
def cyl_take(xp: vec3d, m: vec3d, patch: wp.float64, c: vec3d, rot: mat33d, cyl: wp.array(dtype=wp.float64), s: int,
             sweeps: int, sarm: int, best: wp.float64, sb: int, nb: vec3d, dlt: vec3d, dom: int):
    """``point_grid.pg_mark``'s read of slot ``s``'s cylinder: ``(best, sb, nb, dlt)`` its patch distance, slot,
    normal and the arm (``sarm`` 1: to the cylinder's surface point along the normal; 0, a broken variant: the patch's
    point) where nearer than ``best``, else as given. Round 83, ``dom`` 1 (``roll_contact.DOMAIN``): the point read
    as its domain (:func:`cyl_domain`), its distance compared as the patch's through its centre
    (plus ``patch``: a face's domain lies that much nearer)."""
    cd = wp.float64(0.0)
    cn = vec3d(wp.float64(0.0))
    q = vec3d(wp.float64(0.0))
    if dom != 0:
        cd, cn, q = cyl_domain(xp, patch, c, rot, cyl, s, sweeps)
    else:
        cd, cn, q = cyl_patch(xp, m, patch, c, rot, cyl, s, sweeps)
    b_out = best
    s_out = sb
    n_out = nb
    d_out = dlt
    lift = wp.float64(0.0)
    if dom != 0:
        lift = patch
    if cd + lift < best:
        b_out = cd + lift
        s_out = s
        n_out = cn
        d_out = q
        if sarm != 0:
            d_out = q - cd * cn
        elif dom != 0:   # the broken variant's arm: the patch through the point's centre, a quarter cell under the face
            d_out = q + lift * cn
    return b_out, s_out, n_out, d_out


@wp.func
def sph_take(xp: vec3d, m: vec3d, dom: int, patch: wp.float64, c: vec3d, R: wp.float64, s: int,
             sweeps: int, sarm: int, best: wp.float64, sb: int, nb: vec3d, dlt: vec3d):
    """``point_grid.pg_mark``'s read of slot ``s``'s sphere (centre ``c``, radius ``R``; round 70): ``(best, sb, nb,
    dlt)`` where nearer than ``best``, else as given. ``dom`` 1 (round 83, ``roll_contact.DOMAIN``): the point read as
    its domain (:func:`domain_near`), compared as a face's patch through its centre (plus ``patch``);
    0, the broken variant: the square patch of normal ``m`` (rounds 70-72). ``sarm`` 1: the arm to the sphere's
    surface point (0, a broken variant: the patch's point)."""
    q = vec3d(wp.float64(0.0))
    lift = wp.float64(0.0)
    if dom != 0:
        q = domain_near(xp, patch, c, vec3d(wp.float64(0.0)), BISECT)
        lift = patch
    elif wp.length(m) > wp.float64(0.0) and patch > wp.float64(0.0):
        t1, t2 = patch_tangents(m)
        q = cyl_clamp(wp.dot(c - xp, t1), -patch, patch) * t1 + cyl_clamp(wp.dot(c - xp, t2), -patch, patch) * t2
    rq = xp + q - c
    b_out = best
    s_out = sb
    n_out = nb
    d_out = dlt
    if wp.length(rq) - R + lift < best and wp.length(rq) > wp.float64(0.0):
        b_out = wp.length(rq) - R + lift
        s_out = s
        n_out = wp.normalize(rq)
        d_out = q
        if sarm != 0:
            d_out = c + R * n_out - xp
        elif dom != 0:   # the broken variant's arm: the patch through the point's centre, a quarter cell under the face
            d_out = q + lift * n_out
    return b_out, s_out, n_out, d_out
