"""Round 88 (issue 67 item 2, ``docs/rigid.md`` "Round 88: a ball rests on its sphere"): a rigid sphere's contact
with the particle contact's planes (the grounds and the walls' faces) read on its exact sphere, not on its points.

Before, a rigid body rested on its own points (its Gaussians, skin 0, ``gasp_core.mpm.rigid.rigid_contact``). A ball
sampled every ``s`` then rolls as the polyhedron its Gaussians span: each vertex that comes down is an inelastic
impact, and the stiff rigid contact (``Omega dt`` 1, a penetration of about ``g dt^2``, far under the polyhedron's
sag ``s^2 / 8 R``) never smooths it. Round 87 measured its rolling resistance ``c_rr`` 0.023 with 804 Gaussians on a
5 cm ball and 0.0023 with 3,217, and a slipping ball's spin-up 10.8-43.5 % short on five of ten neighbours of
``tests/test_rolling.py``'s ball.

The exact contact of a sphere of centre ``c`` and radius ``R`` with a plane ``n . x = o`` is one point, ``c - R n``,
at the depth ``o - n . (c - R n)``, and its normal force passes through ``c``. The engines keep their per-point
contact and give it that force exactly: each point ``p`` of a sphere reads the plane at the contact point ``x* = c -
R n`` (its depth, its lever, the friction's point and the restitution's approach speed ``n . (v_p + w x (x* -
x_p))``, the contact point's), with its mass's share of the body's stiffness, ``k_p = (Omega / dt)^2 m_p``
(``Omega dt = gasp_core.mpm.rigid.RIGID_OMEGA_DT``; each plugin's ``plane_point``), unscaled by the touching count.
All its points then take normal impulses in proportion to their masses, whose sum is the sphere's (``Omega dt`` 1 on
the body's whole mass) and whose moment about the mass centre is ``sum m_p (x_p - c) x n j / M = 0``. The friction
acts on the body as one at ``x*`` (each plugin's slide brake, which reads the budget's points). The position-level
non-penetration (``rigid_depth``, ``settle_projection``) and the start's lift (``gasp_core.mpm.rigid.lift_setup``)
read the same depth. Round 89: the ``[[collider]]`` contact too, with the collider's field read at the centre (a
cylinder: at the point's slice of its axis), the depth ``R - phi(c)`` along its gradient there: exact for any surface,
not only a plane (:func:`collider_reach`; ``docs/rigid.md`` "Round 89").

Which bodies: a rigid body whose points fill a sphere (``gasp_core.mpm.roll_contact.round_body`` and
``gasp_core.mpm.roll_contact.sphere_radius``: principal moments within 5 %, no point beyond the volume's radius by
more than a spacing), with the option ``roll_contact`` on (the default), whose exact sphere it already is against
soft bodies. Its radius (:func:`ground_radius`): the sphere its Gaussians lie on, or with none the declared volume's
(the soft contact's). Bodies with faces, cylinders and other round bodies keep their
points. Sources: the contact of a sphere with a half-space (Johnson 1985, "Contact Mechanics", Ch. 4: its normal
force through the centre); rigid-body engines collide a sphere as its primitive, not as a mesh of its samples (the
sphere shapes of Bullet and PhysX, docs/rigid.md "Round 88").
"""
from __future__ import annotations

import numpy as np

import gasp_core.mpm.roll_contact as roll
from gasp_core.mpm.contact import rigid_bodies

#: 1: a rigid sphere or solid cylinder meets the planes on its exact shape (this module); 0: the broken variant, round
#: 87's contact on its points (a polyhedron: the catch of ``tests/test_roll_sizes.py``).
ROUND_GROUND = 1
#: 1: a rigid sphere or solid cylinder meets the ``[[collider]]``s on its exact shape too (round 89: each point reads the
#: collider's field at the centre or at its slice of the axis, :func:`collider_reach`); 0: the broken variant, round
#: 88's collider contact on its points (the catch of ``tests/test_ramp_collider.py``'s ball).
ROUND_COLLIDER = 1
#: A cylinder meets a plane on the line under its axis while ``|n . e|`` (its axis against the plane's normal) is under
#: this (8 degrees from standing on an end); nearer to standing it rests on its end's points, a face.
CYL_LINE = 0.99


def ground_shapes(setup) -> np.ndarray:
    """Per body the exact round shape a rigid body meets the planes with: ``[R, h, e0x, e0y, e0z]``.

    Parameters
    ----------
    setup : SimSetup
        Its ``x`` (n, 3) m, ``p_mass`` (n,) kg, ``p_vol`` (n,) m^3, ``body_id`` (n,) int, ``n_render``, ``faint``,
        ``materials`` and ``options`` (``roll_contact``, ``gasp_core.mpm.roll_contact.on``).

    Returns
    -------
    ndarray, shape (n_bodies, 5), float64
        A rigid sphere (``roll_contact.round_body`` and ``sphere_radius`` > 0): ``[R, 0, 0, 0, 0]``. A rigid solid
        cylinder (``roll_contact.cylinder_shape``): ``[R, h, e0]``, its half-length ``h`` (m) and unit axis ``e0`` in
        its rest frame (the start's world axes). ``R`` (m): the sphere or cylinder its Gaussians lie on (the rows
        under ``n_render`` with mass, but faint ones: the median distance from the mass centre, or from the axis, of
        those within a point spacing of the farthest; a lattice of Gaussians 10 cm across rests with its lowest within
        0.035 dx of the ground, as on its points before), or with none the shape's own (the declared volume's: a fill
        alone's surface half a spacing out, as :func:`gasp_core.mpm.rigid.rigid_contact`'s skin put it). Zeros for
        every other body, and for all without :data:`ROUND_GROUND` or the option.
    """
    rigid = np.asarray(rigid_bodies(setup.materials), bool)
    out = np.zeros((len(rigid), 5))
    if not ROUND_GROUND or not roll.on(setup) or not rigid.any():
        return out
    body = np.asarray(setup.body_id)
    mass = np.broadcast_to(np.asarray(setup.p_mass, np.float64), body.shape)
    vol = np.broadcast_to(np.asarray(setup.p_vol, np.float64), body.shape)
    x = np.asarray(setup.x, np.float64)
    faint = getattr(setup, "faint", None)   # gasp_core.mpm.rigid.touch_rows: a capture's floaters hold nothing up
    surface = np.arange(len(body)) < int(getattr(setup, "n_render", 0) or 0)
    if faint is not None:
        surface &= ~np.asarray(faint, bool)
    for b in np.flatnonzero(rigid):
        sel = (body == b) & (mass > 0.0)
        if sel.sum() < 8:
            continue
        X0 = x[sel] - (mass[sel, None] * x[sel]).sum(0) / mass[sel].sum()
        s, V = roll.point_spacing(X0), float(vol[sel].sum())
        shape = np.zeros(5)
        if roll.round_body(X0):
            shape[0] = roll.sphere_radius(X0, V, s)
        elif roll.CYLINDER:
            shape = roll.cylinder_shape(X0, V, s, vol[sel])
        if shape[0] <= 0.0:
            continue
        on = surface[sel]
        if on.any() and shape[1] > 0.0:   # a cylinder's axis: the one its Gaussians lie around
            shape[2:] = fit_axis(X0[on], shape[2:])
        if on.any():   # its Gaussians are its surface: the sphere or cylinder they lie on
            r = X0[on] - np.outer(X0[on] @ shape[2:], shape[2:])   # from the axis (a sphere's: 0, from the centre)
            d = np.linalg.norm(r, axis=1)
            shape[0] = float(np.median(d[d >= d.max() - s]))
        out[b] = shape
    return out


def fit_axis(X: np.ndarray, e0: np.ndarray) -> np.ndarray:
    """The unit axis through the origin (the mass centre) that the points ``X`` (N, 3) m, a cylinder's Gaussians, lie
    around at one distance: least squares of ``|x - (x . e) e| - R`` over ``e`` and ``R`` (scipy's
    ``least_squares``), from ``e0``. The principal axis ``roll_contact.cylinder_shape`` takes from the moments is off
    by the sampling's asymmetry: 0.75 degrees for 2,400 random Gaussians on a 10 cm cylinder, so that it rested on one
    end's rim and its slipping spin-up fell 13 % short (docs/rigid.md "Round 88")."""
    from scipy.optimize import least_squares
    e0 = np.asarray(e0, np.float64) / np.linalg.norm(e0)
    t1 = np.cross(e0, [1.0, 0.0, 0.0] if abs(e0[0]) <= 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(e0, t1)

    def axis(p):
        e = e0 + p[0] * t1 + p[1] * t2
        return e / np.linalg.norm(e)

    def res(p):
        e = axis(p)
        return np.linalg.norm(X - np.outer(X @ e, e), axis=1) - p[2]

    r0 = float(np.median(np.linalg.norm(X - np.outer(X @ e0, e0), axis=1)))
    return axis(least_squares(res, [0.0, 0.0, r0]).x)


def level_band(shapes: np.ndarray, slop: float) -> np.ndarray:
    """Per body the band on ``|n . e|`` within which a cylinder's line is taken level with the plane (shape
    (n_bodies,), float64; 0 for the others): ``slop / (2 h)``, its ends within the rigid contact's slop (m: the
    engines give ``gasp_core.mpm.rigid.RIGID_SLOP dx``, the depth a resting body may keep) of each other. Beyond it the line tilts by the rest
    (continuous: a cylinder landing on an end rests on it). Its axis, fitted to its Gaussians (:func:`fit_axis`), is
    uncertain by their sampling (0.01-0.07 degrees for 2,400-4,800 random Gaussians): taken exactly, a 10 cm cylinder
    lying on a slope rested on one end's rim (0.17 mm higher at the other) and its slipping spin-up fell 6.1 % short."""
    shapes = np.asarray(shapes, np.float64)
    h = shapes[:, 1]
    return np.where(h > 0.0, float(slop) / (2.0 * np.where(h > 0.0, h, 1.0)), 0.0)


def ground_radius(setup) -> np.ndarray:
    """``ground_shapes(setup)[:, 0]``: per body the radius (m) of its exact round shape, 0.0 for the others."""
    return ground_shapes(setup)[:, 0]


def shape_depth(centre, rot, shape, normal, offset: float, band: float = 0.0) -> float:
    """The depth (m, positive inside) in the plane ``normal . x = offset`` (unit ``normal`` out of the support) of a
    round shape (a :func:`ground_shapes` row) at ``centre`` (3,) m turned by ``rot`` (3, 3) from its rest frame: a
    sphere's ``offset - n . c + R``; a cylinder's lowest point as the engines meet it, ``offset - n . c + R |n_perp| +
    h max(|n . e| - band, 0)`` (``e = rot e0``, ``n_perp`` the normal across the axis, ``band`` its
    :func:`level_band`: within it the line is level; round 89: without it, the start's lift raised the scan-like 5 cm
    cylinder of ``benchmarks/studies/roll_collider89.py`` 26 um over a fitted axis 0.02 degrees off, from which it
    fell, bounced and spun up 2.3 % short)."""
    n = np.asarray(normal, np.float64)
    R, h, e0 = float(shape[0]), float(shape[1]), np.asarray(shape[2:], np.float64)
    e = np.asarray(rot, np.float64) @ e0
    ne = float(n @ e)
    return float(offset - n @ np.asarray(centre, np.float64) + R * np.sqrt(max(1.0 - ne * ne, 0.0))
                 + h * max(abs(ne) - float(band), 0.0))


def collider_reach(setup) -> float:
    """How far (m) beyond a ``[[collider]]``'s extent its distance field must hold for the round bodies of ``setup`` to
    read it at their centres (a sphere) or axes (a cylinder): the largest radius of :func:`ground_shapes`, 0.0 without
    a round body or without :data:`ROUND_COLLIDER` (round 89).

    A sphere of centre ``c`` and radius ``R`` meets a closed surface at the depth ``R - d(c)``, ``d`` the distance to the
    surface (its field), along the field's gradient at ``c``: exact for any surface, not only planes, as long as ``d``
    is read at ``c``. A sphere that touches has ``d(c) <= R``, so a field held ``R`` beyond the surface is read wherever
    it matters (``gasp_core.mpm.grid_tables.grid_tables`` pads the colliders with :func:`gasp_core.colliders.sdf.padded`;
    each plugin's ``round_collider`` reads it). Where the field is not held (a grid too large to pad), each point falls
    back on its own contact, round 88's."""
    if not ROUND_COLLIDER or not getattr(setup, "colliders", None) or getattr(setup, "materials", None) is None:
        return 0.0   # no collider, or tables packed for the colliders alone (no bodies)
    return float(ground_shapes(setup)[:, 0].max(initial=0.0))


def collider_depth(collider, centre, rot, shape, band: float = 0.0, t: float = 0.0) -> tuple[float, np.ndarray | None]:
    """``(depth, n)``: how deep (m, positive inside) a round shape (a :func:`ground_shapes` row) at ``centre`` (3,) m,
    turned by ``rot`` (3, 3) from its rest frame, lies in ``collider`` at its pose at time ``t`` (s), and the unit
    normal out of the collider: the field read at the centre (trilinear, as the engines read it), its gradient the
    normal, the shape's depth under the plane they give (:func:`shape_depth`, with the cylinder's ``band``). ``(0.0, None)`` off the field's grid or
    where the gradient vanishes (round 89: the start's lift, ``gasp_core.mpm.rigid.lift_setup``)."""
    from scipy.ndimage import map_coordinates
    R, T = collider.pose(t)[:2]
    u = (R.T @ (np.asarray(centre, np.float64) - T) - np.asarray(collider.origin)) / float(collider.h)
    if np.any(u < 0.0) or np.any(u > np.asarray(collider.phi.shape) - 1):
        return 0.0, None
    at = u.reshape(3, 1)
    phi = float(map_coordinates(collider.phi, at, order=1)[0])
    g = np.array([map_coordinates(collider.grad[..., a], at, order=1)[0] for a in range(3)])
    if not np.linalg.norm(g) > 0.0:
        return 0.0, None
    n = R @ (g / np.linalg.norm(g))
    return shape_depth(centre, rot, shape, n, float(n @ np.asarray(centre, np.float64)) - phi, band), n
