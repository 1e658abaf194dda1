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
read the same depth. The ``[[collider]]`` contact keeps the points and their rows (``rigid_contact``): a ball on a
mesh ramp still rolls on its Gaussians (round 88 leaves it; ``tests/test_ramp_collider.py``'s ball meets its check).

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

#: 1: a rigid sphere meets the planes on its exact sphere (this module); 0: the broken variant, round 87's contact on
#: its points (a polyhedron: the catch of ``tests/test_roll_sizes.py``).
ROUND_GROUND = 1


def ground_radius(setup) -> np.ndarray:
    """Per body, the exact sphere's radius (m) a rigid sphere meets the planes with, 0.0 for every other body.

    Parameters
    ----------
    setup : SimSetup
        Its ``x`` (n, 3) m, ``p_mass`` (n,) kg, ``p_vol`` (n,) m^3, ``body_id`` (n,) int, ``materials`` and
        ``options`` (``roll_contact``, ``gasp_core.mpm.roll_contact.on``).

    Returns
    -------
    ndarray, shape (n_bodies,), float64
        Where the body is rigid and its points fill a sphere (``roll_contact.sphere_radius`` > 0), with
        :data:`ROUND_GROUND` and the option on: the sphere its Gaussians lie on (the rows under ``n_render`` with
        mass, but faint ones: the median distance from the mass centre of those within a point spacing of the
        farthest; a lattice of Gaussians 10 cm across rests with its lowest within 0.035 dx of the ground, as on its
        points before), or with none the declared volume's radius ``(3 V / 4 pi)^(1/3)`` (a fill alone: its surface
        half a spacing out, as :func:`gasp_core.mpm.rigid.rigid_contact`'s skin put it); else 0.
    """
    rigid = np.asarray(rigid_bodies(setup.materials), bool)
    out = np.zeros(len(rigid))
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
        X0 = np.zeros_like(x)
        X0[sel] = x[sel] - (mass[sel, None] * x[sel]).sum(0) / mass[sel].sum()
        if not roll.round_body(X0[sel]):
            continue
        s = roll.point_spacing(X0[sel])
        out[b] = roll.sphere_radius(X0[sel], float(vol[sel].sum()), s)
        if out[b] > 0.0 and (sel & surface).any():   # its Gaussians are its surface: the sphere they lie on
            d = np.linalg.norm(X0[sel & surface], axis=1)
            out[b] = float(np.median(d[d >= d.max() - s]))
    return out


def sphere_depth(centre, radius: float, normal, offset: float) -> float:
    """The depth (m, positive inside) of a sphere of ``centre`` (3,) m and ``radius`` m in the plane ``normal . x =
    offset`` (unit ``normal`` pointing out of the support): ``offset - normal . (centre - radius normal)``."""
    n = np.asarray(normal, np.float64)
    return float(offset - n @ (np.asarray(centre, np.float64) - radius * n))
