"""Round 70 (issue 67 items 2 and 4, ``docs/rigid.md`` "Round 70: a ball rolling on a soft body, the exact sphere's
contact"): the engine option ``roll_contact``, a round rigid body's contact with a soft body as a smooth surface.

Round 69 measured where a rolling ball's energy goes on a jelly slab: not into the slab (its own ``c_rr`` 0.0017 at E
1e5) but into the contacts. Round 63's band loses the spin (the slab's normals at nodes the ball does not reach);
round 66/67's point contact reads the slab's points as cobbles (``c_rr ~ s / 8R``), drops the ball 2.9 mm at the
start (the lattice ball's blurred shape inside its points) and turns a frictionless ball by its facets' normals, and
its friction per point loses 0.011-0.020 in ``c_rr`` more. The class named there, built here (round 71: on by
default; ``roll_contact = false`` takes round 63's band):

* **the ball's exact shape**: a round rigid body whose points fill a sphere (:func:`sphere_radius`: its principal
  moments equal, no point beyond the sphere of its declared volume) is that sphere, of the radius its volume gives
  (``sum p_vol = 4/3 pi R^3``: the radius the scene asked), centred on its mass centre; its distance ``|q| - R`` and
  normal ``q / |q|`` are exact (no lattice, no facets, no shrink: seated where its points say);
* **a surface smooth at the lattice's scale**: each soft point is read as its square patch of the soft body's face
  (half-size :data:`PATCH` cells, half the points' spacing: the patches tile the face), normal to its field's outward
  normal (round 67's), and the patch's least distance to the sphere is taken exactly (:func:`sphere_patch`): a lattice
  of points reads as its flat face, a quarter cell (``SKIN``) above the top points;
* **the soft points' compliance** (:data:`STIFFNESS`, round 67's): each touching point gives as its cube of material
  would, ``k = E s``, solved implicitly in the normal passes (the gap closed by the spring);
* **friction one impulse a patch**: the normal impulses are round 67's constraint of the grid (its Jacobi passes,
  frictionless); then the tangential impulse is one per contact patch (a rigid body and a soft body, a pair), the
  patch's mean slip (weighted by the normal impulses) driven to zero by :data:`FRICTION_PASSES` Jacobi steps over the
  patch's own response (the grid's, the body's at the patch's centre), capped at ``mu`` times the patch's normal
  impulse, and shared among its points in proportion to their normal impulses (so its moment is the centre's).

The contact's arm (its friction's and its reaction's moment) is the sphere's surface point along the normal, not
the soft point's patch: the patch lies a quarter cell (``SKIN``) under the slab's face, and an arm there holds the
ball's velocity at that depth (``v = w (R + s/2)``: the ball slips).

Broken variants for the checks: :data:`EXACT` 0 takes the lattice ball's shape (round 66's ``body_sdf``) for the
sphere's; :data:`SURFACE_ARM` 0 the arm at the patch; :data:`PATCH_FRICTION` 0 round 67's friction per point;
``rigid_collider.FRICTION`` 0 no friction; round 71: :data:`FALLBACK` 0 a round body that is no sphere takes the
lattice's point contact, :data:`PAIRS` 0 every slot's patch one (cross-talk); round 72: :data:`CYLINDER` 0 a
cylinder takes the FALLBACK again, :data:`CYL_AXIS` 1 a wrong axis (the body frame's next axis), :data:`CYL_TURN` 0
the axis turned the wrong way.

Round 71 (``docs/rigid.md`` "Round 71: roll_contact on neighbours' scenes"): a round rigid body that is not a sphere
(an ellipsoid; a cylinder or a cube has faces and never took the point contact) takes the default contact under the
option, round 63's node band, the option off's bits.

Round 72 (``docs/rigid.md`` "Round 72: a cylinder rolling on a soft body"): a rigid body whose points fill a solid
circular cylinder (:func:`cylinder_shape`: its radius, half-length and axis in its rest frame) takes the exact contact
too, as a second shape of the same contact: its capped cylinder's distance to each soft point's patch
(:func:`cylinder_patch`: the patch's point nearest the axis, then the exact signed distance and normal there), the
arm at the cylinder's surface point along the normal. Its axis turns with the body (the rotation ``R e0``). Other
round bodies (an ellipsoid) keep the FALLBACK.

Round 73 (``docs/rigid.md`` "Round 73"): a coarse lattice cylinder (n_grid 24: 3 points a radius) is held to the disc
its cells cover as well as to the declared volume's (:data:`CYL_COVER`); round 72's rule found none at n_grid 24.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.options import Option

ROLL_CONTACT = Option(
    "roll_contact", True, "a round rigid body's contact with a soft body (round 70, docs/rigid.md; the default since "
    "round 71): true (the default): a sphere's (round 72: or a solid cylinder's) exact shape against each soft "
    "point's patch of its body's face, a constraint of the grid velocities, friction one impulse a patch (other round "
    "bodies and bodies with faces keep the band); roll_contact = false: round 63's node band for every rigid body "
    "(a ball rolling on jelly loses its spin, with friction it stops)", kind="bool")

#: Each soft point's patch half-size, cells (a quarter: half the points' spacing at 2 a cell, tiling the face).
PATCH = 0.25
#: The normal constraint's Jacobi passes a substep (round 67's ``GRID_PASSES``).
NORMAL_PASSES = 4
#: The patch friction's Jacobi passes a substep.
FRICTION_PASSES = 4
#: Each soft point's own compliance in the contact, ``k = STIFFNESS E s`` (round 67's ``rigid_sdf.STIFFNESS``, here the
#: option's: ``rigid_sdf.point_data``'s ``comp``): the sub-grid give of its cube of material. 0: a hard contact
#: (measured, n_grid 32-48, R 3 / 4.5 cm, E 1e5: frictionless speed -4.2 to -5.8 % in 0.2 s; with 1: -2.6 to -3.6 %).
STIFFNESS = 1.0
#: Broken variants: EXACT 0 the lattice ball's shape (``rigid_sdf.body_sdf``) instead of the exact sphere;
#: PATCH_FRICTION 0 round 67's friction per point (measured: the same figures, docs/rigid.md); SURFACE_ARM 0 the
#: contact's arm to the soft point's patch (a quarter cell under the slab's face) instead of the sphere's surface:
#: friction then holds the ball's velocity at that depth, and the ball slips (n_grid 32, R 3 cm, mu 0.5: v 0.509,
#: w R 0.455 at 0.09 s; round 83, under :data:`DOMAIN`: the domain's point less ``PATCH`` cells along the normal, the
#: same plane through the soft point's centre, as the domain's point lies on the face).
EXACT = 1
PATCH_FRICTION = 1
SURFACE_ARM = 1
#: Round 71: a round rigid body that is not a sphere (an ellipsoid; :func:`sphere_radius` 0; round 72: not a solid
#: cylinder, :func:`cylinder_shape`, unless :data:`CYLINDER` 0) takes the
#: default contact under the option (round 63's node band, as with the option off: the same launches, the same bits),
#: not the lattice shape of round 66/67's point contact (``rigid_sdf.round_body``), which the option never tuned.
#: 0: the broken variant (round 70's behaviour: such a body takes the lattice's point contact under the option).
FALLBACK = 1
#: Round 71: the broken variant PAIRS 0 merges every slot's patch with a soft body into one (the pair index without
#: its slot: two balls on one slab share one friction impulse, the cross-talk ``roll_neighbours.py``'s ``two`` reads).
PAIRS = 1
#: Round 72: 1: a rigid solid cylinder (:func:`cylinder_shape`) takes the exact contact; 0: the broken variant, round
#: 71's FALLBACK for it (round 63's band: the cylinder does not roll on jelly).
CYLINDER = 1
#: Round 72: a broken variant: CYL_AXIS k > 0 takes the body frame's axis ``(i + k) % 3`` for the cylinder's axis ``i``
#: (a wrong axis); 0: the axis its points give.
CYL_AXIS = 0
#: Round 72: a broken variant: CYL_TURN 0 turns the cylinder's axis by the transpose of the body's rotation (the wrong
#: way; 1: ``R e0``, the body's).
CYL_TURN = 1
#: Round 73: the solid disc a cylinder's second moment across its axis is held to (:func:`cylinder_shape`): 1: the
#: declared volume's radius or the disc its points' lattice cells cover (``N s^3 = pi R^2 L``), whichever is nearer;
#: 0: the broken variant, round 72's rule, the declared volume's only. A lattice disc of a few cells a radius covers an
#: area that aliases the declared one by up to +-15 % (3 cells: 32 cells for 28.3; measured, docs/rigid.md "Round 73"),
#: so its moment missed the declared disc's by 15 % at n_grid 24 (R 3 cm, 1.5 dx): the cylinder took the band and did
#: not roll. Against its own cover a lattice disc of 1.5-8 cells a radius is within 4.7 %; a tube is far off either.
CYL_COVER = 1
#: Round 72: the coordinate-descent sweeps of the patch's point nearest the cylinder's axis (:func:`cylinder_patch`).
CYL_SWEEPS = 4
#: Round 83 (``docs/rigid.md`` "Round 83: a soft body's edge under a round body"): 1: each soft point is read as its
#: domain, the cube of half-size :data:`PATCH` cells on the fill's axes (uGIMP's particle domain, fixed in size and
#: orientation: Bardenhagen & Kober 2004, CMES 5, 477), and the round body's least distance over it is taken
#: (:func:`domain_point`); a lattice's faces, edges and corners then read as the faces they are. Turned with each
#: point's ``F`` (its columns made orthonormal), a cylinder resting on jelly at n_grid 64 swayed 4.4 mm (1.9 mm on
#: the fill's axes, 1.6 mm before), so the domain is not turned; a soft body turned far from its rest reads its face
#: as steps (up to ``(sqrt 2 - 1) a`` at 45 degrees). 0: the broken variant, rounds 70-72's square patch normal to the
#: grid's mass gradient, which the kernel spreads over 1.5 cells: within it of a face's edge the patches lean up into
#: a body resting there (a rigid cylinder longer than the jelly slab under it was thrown 6-7 mm from rest and rolled
#: 14-20 % slow at n_grid 24).
DOMAIN = 1
#: Round 83: the bisections of :func:`domain_point`'s nearest point to a line.
DOMAIN_BISECT = 48
#: A body is a sphere where its principal moments agree within this fraction and no point lies beyond the sphere of
#: its volume by more than a point spacing.
SPHERE_TOL = 0.05


def on(setup) -> bool:
    """Whether a setup takes the option (its ``[engine] options``; round 71: on unless ``roll_contact = false``)."""
    return bool(dict(getattr(setup, "options", None) or {}).get("roll_contact", ROLL_CONTACT.default))


def sphere_radius(X0: np.ndarray, volume: float, spacing: float) -> float:
    """The exact sphere of a rigid body's points ``X0`` ((N, 3) m about its mass centre) of total ``volume`` (m^3):
    its radius ``(3 V / 4 pi)^(1/3)``, or 0.0 where the points do not fill a sphere (principal moments unequal by
    more than :data:`SPHERE_TOL`, or a point more than ``spacing`` beyond that radius)."""
    X0 = np.asarray(X0, float)
    R = float((3.0 * volume / (4.0 * np.pi)) ** (1.0 / 3.0))
    ev = np.linalg.eigvalsh(np.sum(X0 * X0) * np.eye(3) - X0.T @ X0)
    if ev[0] <= 0.0 or (ev[-1] - ev[0]) / ev[-1] > SPHERE_TOL:
        return 0.0
    if np.linalg.norm(X0, axis=1).max() > R + spacing:
        return 0.0
    return R


def patch_frame(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents of a patch of normal ``m`` (3,) (as the kernels take them: ``m x e_x``, or ``m x e_y`` near
    ``e_x``)."""
    t1 = np.cross(m, [1.0, 0.0, 0.0] if abs(m[0]) <= 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(m, t1)


def sphere_patch(x: np.ndarray, m: np.ndarray, a: float, c: np.ndarray, R: float) -> tuple[float, np.ndarray,
                                                                                            np.ndarray]:
    """``(phi, n, q)``: the square patch centred on ``x`` (3,), normal ``m`` (unit), half-size ``a`` (m), against the
    sphere of centre ``c``, radius ``R``: the least distance over the patch (the patch's point ``x + q`` nearest the
    centre: the centre's projection onto its plane, clamped to the square), the sphere's outward normal there.
    ``m`` zero: the point itself."""
    x, c = np.asarray(x, float), np.asarray(c, float)
    q = np.zeros(3)
    if np.linalg.norm(m) > 0.0 and a > 0.0:
        t1, t2 = patch_frame(np.asarray(m, float))
        q = np.clip((c - x) @ t1, -a, a) * t1 + np.clip((c - x) @ t2, -a, a) * t2
    r = x + q - c
    d = float(np.linalg.norm(r))
    return d - R, r / max(d, 1e-300), q


def domain_point(x: np.ndarray, a: float, c: np.ndarray, e: np.ndarray | None = None) -> np.ndarray:
    """Round 83 (:data:`DOMAIN`): the offset ``q`` (3,) m of the point of a soft point's domain nearest the point
    ``c`` (``e`` None: a sphere's centre) or the line through ``c`` along the unit ``e`` (a cylinder's axis).

    The domain is the cube ``x + u``, ``|u_k| <= a`` (``a`` its half-size, m) on the fill's axes (the world's).
    Nearest a point: ``u`` the clamp of the point's offset (exact). Nearest a line ``b + t e`` (``b = c - x``): the
    squared distance from its point at ``t`` to the cube is convex in ``t``, its derivative ``2 (l - clamp(l)) . e``
    non-decreasing, negative a half-diagonal before the line's point nearest the cube's centre and positive as far
    after: :data:`DOMAIN_BISECT` bisections of it (exact to ``2^-48`` of the cube's diagonal), then ``u`` the clamp of
    the line's point there.
    """
    b = np.asarray(c, float) - np.asarray(x, float)
    if e is None:
        return np.clip(b, -a, a)
    e = np.asarray(e, float)
    t0 = -float(b @ e)
    lo, hi = t0 - np.sqrt(3.0) * a, t0 + np.sqrt(3.0) * a
    for _ in range(DOMAIN_BISECT):
        t = 0.5 * (lo + hi)
        l = b + t * e
        if (l - np.clip(l, -a, a)) @ e < 0.0:
            lo = t
        else:
            hi = t
    return np.clip(b + 0.5 * (lo + hi) * e, -a, a)


def cylinder_at(y: np.ndarray, e: np.ndarray, R: float, h: float) -> tuple[float, np.ndarray]:
    """The solid capped cylinder's signed distance (m) and outward normal at ``y`` (3,), the point less the centre;
    unit axis ``e``, radius ``R``, half-length ``h`` (the rim's where beyond both the side and the cap)."""
    y, e = np.asarray(y, float), np.asarray(e, float)
    z = float(y @ e)
    rr = y - z * e
    rho = float(np.linalg.norm(rr))
    dr, dz = rho - R, abs(z) - h
    er = rr / max(rho, 1e-300)
    ez = np.sign(z) * e
    if dr > 0.0 and dz > 0.0:
        phi = float(np.hypot(dr, dz))
        return phi, (dr * er + dz * ez) / phi
    if dr >= dz:
        return dr, er
    return dz, ez


def patch_friction(mu: float, lam: np.ndarray, ut: np.ndarray, S: float, J: np.ndarray) -> np.ndarray:
    """One Jacobi step of a patch's friction (module notes): the points' normal impulses ``lam`` (N,), their slips
    ``ut`` (N, 3), the patch's response ``S`` (m/s per kg m/s), its impulse so far ``J`` (3,): the new ``J``, capped at
    ``mu sum(lam)``."""
    L = float(np.sum(lam))
    if L <= 0.0:
        return np.zeros(3)
    J1 = np.asarray(J, float) - (np.asarray(lam) @ np.asarray(ut)) / L / S
    n = float(np.linalg.norm(J1))
    return J1 * (mu * L / n) if n > mu * L else J1


def cylinder_shape(X0: np.ndarray, volume: float, spacing: float, weights=None) -> np.ndarray:
    """Round 72: the exact solid cylinder of a rigid body's points ``X0`` ((N, 3) m about its mass centre, rest frame)
    of total ``volume`` (m^3): ``[R, h, e0x, e0y, e0z]`` (radius, half-length, unit axis), or zeros where the points
    fill no cylinder. Each principal axis (and each frame axis) is tried as the axis ``e0``: its length ``L`` from the
    points' second moment along it, ``L^2 / 12 = <z^2> + s^2 / 12`` (each point a cube of side ``s``: the extent plus a
    spacing for cell-centred points), ``R = sqrt(V / (pi L))``; it is a cylinder where no point lies beyond its ends or
    ``R`` by more than a spacing, the points' second moment across it is the solid cylinder's within
    :data:`SPHERE_TOL` (``<rho^2> + s^2/6 = R^2 / 2``; round 73, :data:`CYL_COVER`: of ``R`` or of the radius the
    points' cells cover, ``N s^3 = pi R^2 L``), its cross-section is round (its support in
    8 directions across the axis within a spacing of each other: a square's differ by 0.41 of its half-side) and each
    end is a full disc (its last layer reaches ``R`` within a spacing: an ellipsoid's does not). ``weights`` (N,): the
    moments weighted by them (round 88's ground shape: the points' volumes, where a dense shell of Gaussians over a
    fill outnumbers it); None: each point alike."""
    X0 = np.asarray(X0, float)
    w = np.ones(len(X0)) if weights is None else np.asarray(weights, float)
    out = np.zeros(5)
    if len(X0) < 8:
        return out
    _, vecs = np.linalg.eigh(np.sum(w * (X0 * X0).sum(1)) * np.eye(3) - (w[:, None] * X0).T @ X0)
    cands = [vecs[:, i] for i in range(3)] + list(np.eye(3))
    s = float(spacing)
    for e in cands:
        e = e / np.linalg.norm(e)
        z = X0 @ e
        rr = X0 - np.outer(z, e)
        rho = np.linalg.norm(rr, axis=1)
        L = float(np.sqrt(12.0 * np.average(z * z, weights=w) + s * s))
        R = float(np.sqrt(volume / (np.pi * L)))
        if np.abs(z).max() > 0.5 * L + s:
            continue
        m2 = np.average(rho * rho, weights=w) + s * s / 6.0
        R_own = float(np.sqrt(len(X0) * s ** 3 / (np.pi * L)))   # round 73: the disc the lattice's cells cover
        if min(abs(m2 / (R * R / 2.0) - 1.0), abs(m2 / (R_own * R_own / 2.0) - 1.0) if CYL_COVER else np.inf) > \
                SPHERE_TOL or rho.max() > R + s:
            continue
        t1 = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) <= 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(e, t1)
        sup = [float((rr @ (np.cos(a) * t1 + np.sin(a) * t2)).max()) for a in np.arange(8) * np.pi / 8.0]
        if max(sup) - min(sup) > s:
            continue
        ends = [rho[z > z.max() - 0.5 * s].max(), rho[z < z.min() + 0.5 * s].max()]
        if min(ends) < R - s:
            continue
        if CYL_AXIS:   # a broken variant: a wrong axis
            e = np.roll(e, int(CYL_AXIS))
        out[:] = [R, 0.5 * L, *e]
        return out
    return out


def cylinder_patch(x: np.ndarray, m: np.ndarray, a: float, c: np.ndarray, e: np.ndarray, R: float,
                   h: float) -> tuple[float, np.ndarray, np.ndarray]:
    """``(phi, n, q)``: the square patch centred on ``x`` (3,), normal ``m``, half-size ``a`` (m), against the solid
    capped cylinder of centre ``c``, unit axis ``e``, radius ``R``, half-length ``h`` (the kernels' read): the patch's
    point ``x + q`` nearest the axis's line (:data:`CYL_SWEEPS` sweeps of coordinate descent over the square from its
    centre: the distance squared to the line is a convex quadratic), the cylinder's signed distance and outward normal
    there (the rim's where beyond both the side and the cap)."""
    x, c, e = np.asarray(x, float), np.asarray(c, float), np.asarray(e, float)
    d = x - c
    q = np.zeros(3)
    if np.linalg.norm(m) > 0.0 and a > 0.0:
        t1, t2 = patch_frame(np.asarray(m, float))
        a1, a2, b = t1 - (t1 @ e) * e, t2 - (t2 @ e) * e, d - (d @ e) * e
        u = v = 0.0
        for _ in range(CYL_SWEEPS):
            if a1 @ a1 > 1e-12:
                u = float(np.clip(-(a1 @ (b + v * a2)) / (a1 @ a1), -a, a))
            if a2 @ a2 > 1e-12:
                v = float(np.clip(-(a2 @ (b + u * a1)) / (a2 @ a2), -a, a))
        q = u * t1 + v * t2
    phi, n = cylinder_at(d + q, e, R, h)
    return phi, n, q


def round_body(X0: np.ndarray) -> bool:
    """Whether a rigid body (points ``X0`` (N, 3) m about its centre, rest frame) takes the point contact with
    :data:`POINT_CONTACT` on: no face along its frame's or principal axes (round 65's support table,
    ``gasp_core.mpm.rigid_support``: the flatness at those 12 rows, the mean of two tangents, under 1/2 at every
    one: a ball; a block, a slab, a plate have faces there and keep round 63's node band, which holds faces)."""
    from gasp_core.mpm.rigid_support import flatness, support_table
    X0 = np.asarray(X0, float)
    dirs, h, curv, _ = support_table(X0, point_spacing(X0))
    for i in range(len(dirs) - 12, len(dirs)):
        d = dirs[i] / np.linalg.norm(dirs[i])
        t1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(d, t1)
        c = curv[i]
        K = np.array([[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]])
        f = 0.5 * (flatness(float(t1 @ K @ t1), float(h[i])) + flatness(float(t2 @ K @ t2), float(h[i])))
        if f >= 0.5:
            return False
    return True


def point_spacing(X: np.ndarray) -> float:
    """The median nearest-neighbour distance of points ``X`` (N, 3) m."""
    from scipy.spatial import cKDTree
    d, _ = cKDTree(X).query(X, k=2)
    return float(np.median(d[:, 1]))
