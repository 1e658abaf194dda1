"""The rigid limit of a stiff elastic body in a grid (MPM) engine (issue 40, ``docs/rigid.md``).

A body whose material has ``model = "rigid"`` (:class:`gasp_core.seam.setup.Material`) keeps its P2G, grid update
and G2P like every body, so it couples with the others through the shared grid; after each G2P its points'
velocities are projected onto one rigid motion that keeps the body's linear momentum and its angular momentum,
APIC's affine part included (:func:`rigid_project`), its points are put back on the rigid pose, its ``C`` is set
to :data:`APIC_SPIN` times the spin's skew matrix (0 since round 67: the body turns with its own inertia) and its
``F`` to the rotation. Its stress is zero (its Lame parameters are set to zero,
:func:`zero_stress`), so its wave speed sets no step: the step follows the velocity CFL and the contact's own
stable step (:func:`step_view`, :func:`rigid_contact`).

Sources: the rigid projection of a particle velocity field is the rigid-body limit used in MPM rigid coupling
(Hu et al. 2018, "A moving least squares material point method with displacement discontinuity and two-way rigid
body coupling", Sec. 5, where rigid bodies are advanced from the momentum the grid gives them); APIC's angular
momentum of a particle, ``m_p x_p x v_p + m_p eps : (B_p^T)`` with ``B_p = C_p D_p`` and ``D_p = dx^2 / 4 I`` for
quadratic B-splines (Jiang et al. 2015, "The affine particle-in-cell method", Sec. 5.3).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from gasp_core.mpm.contact import DAMPING, SKIN, rigid_bodies
from gasp_core.mpm.materials import P_LAM, P_MU
import gasp_core.mpm.round_ground as round_ground
from gasp_core.mpm.round_ground import ground_shapes, shape_depth

#: Elastic modulus (Pa) a rigid body shows the step and contact rules of the grid engines
#: (:func:`step_view`): small enough that neither its wave speed nor its contact frequency sets a step.
NOMINAL_E = 1.0
#: ``Omega dt`` of a rigid body's contact at the step the engine takes: ``Omega = sqrt(k N / M)``, the body's
#: frequency on the ``N`` points of its largest flat face (:func:`rigid_contact`). Symplectic Euler on an
#: oscillator is stable below 2; 1 keeps the impact resolved over about 3 substeps.
RIGID_OMEGA_DT = 1.0
#: Damping ratio of a rigid body's contact per point (``c_p = 2 RIGID_DAMPING sqrt(k_p m_p)``), the particle contact's
#: (``gasp_core.mpm.contact.DAMPING``), once the body settles: while it bounces the engines apply the restitution
#: asked for instead (issue 53, ``gasp_core.mpm.restitution``). As the bounce's law this damping gave a
#: restitution set by how many points touch (0.75 at n_grid 24, 0.855 at 40, 0.50 for a donut landing flat, the
#: same for steel and wood).
RIGID_DAMPING = DAMPING
#: The largest ``M |r|^2 / I`` of a contact point's lever about the body's centre that a rigid body's contact
#: stiffness allows for when few of its points touch (:func:`support_scale`): 3 for a thin plate on a corner or a rod
#: on its end, 2 for a ring on its rim.
RIGID_LEVER = 3.0
#: Penetration (cells) a resting rigid body's deepest contact point may keep: deeper, the body is moved out along the
#: support's normal to this depth after its velocity update, without gaining speed (:func:`gasp_core.mpm.rigid_friction.settle_projection`,
#: issue 53). Bullet's split impulse and Box2D's ``b2_linearSlop`` leave such an allowance so that the contact keeps
#: touching (here the penalty still carries part of the weight and gives the friction its budget); half the issue's
#: 0.1 dx.
RIGID_SLOP = 0.05
#: The share of a rigid body's spin ``w`` its points carry in their APIC affine parts after the projection
#: (``C = APIC_SPIN [w]``, :func:`rigid_project`, each grid plugin's ``rigid_apply``); the body's inertia in every
#: rigid law is then the lattice's plus ``APIC_SPIN M dx^2 / 2 1`` (each point's ``D = dx^2 / 4 I`` books
#: ``m dx^2 / 2 w`` of angular momentum in its ``C = [w]``), so that the angular momentum the grid holds is the
#: body's either way. 1 to round 66 (a ball of 2 cells' radius rolled 7.3 % slower than ``5/7 g sin``); 0 since
#: round 67 (``docs/rigid.md`` "Round 67: the rigid body's own inertia"): the points carry no affine spin, the
#: body responds with its own inertia. The projection still reads the affine parts G2P gives (APIC's angular momentum).
APIC_SPIN = 0.0
#: Fixed-point passes (0 to 4: the kernels' loop runs at most 4) of the rigid update's implicit midpoint rotation:
#: the spin that turns the body over a substep is ``I(R_h)^-1 L`` at the half-turned pose ``R_h = exp(dt w / 2) R``
#: (each grid plugin's ``rigid_update``). 0 is the explicit step before round 67 (the spin at ``R``), under which a
#: tumbling 6 x 4 x 2 cm box at 10 rad/s gained 7.6 % of its energy in a second at 2 substeps a frame (3.0 % with
#: APIC's inertia); ``docs/rigid.md`` "Round 67".
ROTATION_PASSES = 4


def rigid_mask(materials) -> np.ndarray:
    """Per body, True where ``material.model == "rigid"`` (shape (n_bodies,), bool)."""
    return rigid_bodies(materials)


def step_view(setup):
    """The setup as the step and contact rules see it: each rigid body's ``E`` is :data:`NOMINAL_E`.

    A rigid body has no stress, so its stiffness sets no wave speed, and its contact is :func:`rigid_contact`'s,
    not the one of its ``E``; the rules (``choose_dt``, ``contact_model``, ``contact_coefficients``) then take
    the step, the contact model and the other bodies' coefficients from the other bodies. Returns ``setup``
    itself when no body is rigid, else a shallow copy (``dataclasses.replace``).
    """
    rigid = rigid_mask(setup.materials)
    if not rigid.any():
        return setup
    mats = [dataclasses.replace(m, E=NOMINAL_E) if r else m for m, r in zip(setup.materials, rigid)]
    return dataclasses.replace(setup, materials=mats)


def zero_stress(kinds: np.ndarray, params: np.ndarray, materials, elastic_code: int) -> tuple[np.ndarray, np.ndarray]:
    """``material_table``'s rows with each rigid body's Lame parameters zero and its model the plain elastic one
    (``elastic_code``: no return mapping), so its stress is zero whatever its ``F``."""
    kinds, params = np.array(kinds), np.array(params, dtype=np.float64)
    rigid = rigid_mask(materials)
    params[rigid, P_MU] = 0.0
    params[rigid, P_LAM] = 0.0
    kinds[rigid] = elastic_code
    return kinds, params


def face_points(x: np.ndarray, h: float) -> int:
    """The most points within ``h`` (m) of one of the six extremes of ``x`` (shape (n, 3), m): the points of
    the body's largest axis-aligned flat face, which may meet a plane at once."""
    if len(x) == 0:
        return 0
    return int(max(max(np.sum(x[:, d] <= x[:, d].min() + h), np.sum(x[:, d] >= x[:, d].max() - h))
                   for d in range(3)))


def face_counts(setup) -> np.ndarray:
    """Per body the ``N`` of :func:`rigid_contact` (the points of its largest flat face, :func:`face_points`, at
    least 1) for a rigid body, 1 for the others: shape (n_bodies,), float64. The engines scale a rigid body's
    contact stiffness by ``N / max(N, N_touch)`` (``N_touch`` the points that touched in the last substep), so the
    body keeps ``Omega dt = RIGID_OMEGA_DT`` when more points touch than ``N`` (a donut of 65,036 points with
    ``N`` = 487 rested on about 2,000, at ``Omega dt`` about 2: it chattered 5 mm a frame)."""
    out = np.ones(len(setup.materials))
    body, vol = np.asarray(setup.body_id), np.asarray(setup.p_vol, np.float64)
    touching = touch_rows(setup)
    for b in np.flatnonzero(rigid_mask(setup.materials)):
        sel = (body == b) & (vol > 0.0)
        if sel.any():
            out[b] = max(face_points(np.asarray(setup.x)[sel & touching], float(np.median(np.cbrt(vol[sel])))), 1)
    return out


def touch_rows(setup) -> np.ndarray:
    """The rows a rigid body may rest on: all but the rendered rows that only faint Gaussians move
    (:attr:`gasp_core.seam.setup.SimSetup.faint`, a capture's floaters; issue 53: three of the wooden donut's, of
    opacity 0.002-0.004 hanging 9 mm under its bottom, tipped it 1.46 deg, where the hull of its Gaussians of
    opacity 0.1 or more is 0.13 deg off flat under its mass centre). Shape (n,), bool."""
    faint = getattr(setup, "faint", None)
    return np.ones(len(setup.x), bool) if faint is None else ~np.asarray(faint, bool)


def support_scale(n_face, n_touch):
    """The factor on a rigid body's contact stiffness ``k_p`` (:func:`rigid_contact`) with ``n_touch`` of its points
    touching in the last substep (the engines' ``contact_impulse``): ``N / max(n_t, min(N, RIGID_LEVER n_t))``,
    ``N = n_face`` (:func:`face_counts`), ``n_t = max(n_touch, 1)``.

    On more than ``N`` points ``N / n_t``: the body keeps ``Omega dt = RIGID_OMEGA_DT`` (issue 53: a donut on about
    2,000 points chattered at ``Omega dt`` 2). On fewer than ``N / RIGID_LEVER`` points ``N / (RIGID_LEVER n_t)``:
    its few points hold its weight at about ``RIGID_LEVER g dt^2`` of depth instead of ``g dt^2 N / n_t`` (issue 53:
    the wooden donut set down flat rested on 5-13 of its Gaussians that hang under its bottom, the lowest 0.46-0.59
    dx in the ground, ``N`` = 487), while a contact point at a lever ``r`` (its effective mass ``M / (1 + M r^2 /
    I)``) stays at ``Omega dt <= 1``. Between, 1 (the stiffness of issue 40)."""
    n_face = np.asarray(n_face, np.float64)
    n_t = np.maximum(np.asarray(n_touch, np.float64), 1.0)
    return n_face / np.maximum(n_t, np.minimum(n_face, RIGID_LEVER * n_t))


def rigid_contact(setup, dt: float, coeffs: np.ndarray) -> np.ndarray:
    """The particle contact's ``(k_p, c_p, s_p)`` (``gasp_core.mpm.contact.contact_coefficients``) with each
    rigid body's rows replaced: its stiffness follows the step, not its ``E``.

    ``k_p = (RIGID_OMEGA_DT / dt)^2 M / N`` (N/m), ``c_p = 2 RIGID_DAMPING sqrt(k_p m_p)`` (N s/m; the engines use it
    once the body settles, the restitution's law while it bounces: ``gasp_core.mpm.restitution``), the skin
    unchanged for its fill points and 0 for the scene's own Gaussians that carry mass (the first ``n_render``
    points): they are its surface, so it rests on them, not half a point spacing above them (issue 53: a 10 cm ball
    of surface Gaussians rested with its lowest ones 2.6 mm, 0.105 dx, over the ground at n_grid 24, 2.3 mm at 40),
    and no contact (``k_p = c_p = 0``) on the rows only faint Gaussians move (:func:`touch_rows`: a floater holds no
    rigid body up; ``N`` counts none of them); ``M`` the body's mass (kg) and ``N`` the points of its largest flat
    face (:func:`face_points`, within one point spacing), so the body on that face oscillates at
    ``Omega = RIGID_OMEGA_DT / dt``, stable and resolved at the step ``dt`` (s) the engine takes. A rigid body's
    points move together, so the step is bounded by the body's frequency, not by one node's (the elastic contact's
    ``contact_dt``).

    Parameters
    ----------
    setup : SimSetup
    dt : float
        The substep, s.
    coeffs : ndarray, shape (n, 3)
        The coefficients of the other bodies (any rows for the rigid ones).

    Returns
    -------
    ndarray, shape (n, 3), float64
    """
    out = np.array(coeffs, dtype=np.float64)
    body = np.asarray(setup.body_id)
    m, vol = np.asarray(setup.p_mass, np.float64), np.asarray(setup.p_vol, np.float64)
    surface = np.arange(len(vol)) < int(getattr(setup, "n_render", 0) or 0)   # the scene's own Gaussians
    touching = touch_rows(setup)
    for b in np.flatnonzero(rigid_mask(setup.materials)):
        sel = (body == b) & (vol > 0.0)
        if not sel.any():
            continue
        h = float(np.median(np.cbrt(vol[sel])))
        M = float(m[sel].sum())
        n_face = max(face_points(np.asarray(setup.x)[sel & touching], h), 1)
        k = (RIGID_OMEGA_DT / dt) ** 2 * M / n_face
        rows = body == b
        holds = (vol[rows] > 0.0) & touching[rows]   # a floater holds no rigid body up (touch_rows)
        out[rows, 0] = np.where(holds, k, 0.0)
        out[rows, 1] = np.where(holds, 2.0 * RIGID_DAMPING * np.sqrt(k * m[rows]), 0.0)
        out[sel, 2] = np.maximum(out[sel, 2], 0.0)   # a rigid body placed inside a support is lifted (lift_setup)
        out[sel & surface, 2] = 0.0
        if not (sel & surface).any():   # a fill alone: its surface half a spacing out, wherever it was put
            out[sel, 2] = SKIN * np.cbrt(vol[sel])
    return out


def lift_setup(setup):
    """The setup with each rigid body moved out of the particle contact's planes (the grounds and the walls' faces)
    until its deepest point touches (:func:`gasp_core.mpm.rigid_friction.settle_projection`'s move before the first substep, without its slop: a
    body placed inside the ground is lifted out, not thrown; issue 53 measured a slab put 0.35 dx into the ground
    thrown up at 2.6 m/s in its first frame, and one lifted to the slop, 0.05 dx deep on its whole face, rose at
    0.36 m/s). Its points' penetration takes :func:`rigid_contact`'s skins
    (0 for its own Gaussians, half a spacing for a fill alone). Returns ``setup`` itself when nothing moves, else a
    shallow copy with ``x`` replaced."""
    from gasp_core.colliders.sdf import padded
    from gasp_core.mpm.contact import contact_coefficients, contact_planes
    rigid = rigid_mask(setup.materials)
    if not rigid.any():
        return setup
    view = step_view(setup)
    normals, rows = contact_planes(view)
    reach = round_ground.collider_reach(setup)   # round 89: the colliders' fields as the engines read them (padded)
    cols = [padded(c, reach) for c in getattr(setup, "colliders", None) or []] if reach > 0.0 else []
    if not len(normals) and not cols:
        return setup
    skin = rigid_contact(setup, 1.0, contact_coefficients(view))[:, 2]
    x = np.array(setup.x, dtype=np.float64)
    body, vol = np.asarray(setup.body_id), np.asarray(setup.p_vol, np.float64)
    moved, touching = False, touch_rows(setup)
    shapes, m = ground_shapes(setup), np.asarray(setup.p_mass, np.float64)
    band = round_ground.level_band(shapes, RIGID_SLOP * float(setup.dx))   # as the engines' round_point reads it
    for b in np.flatnonzero(rigid):
        sel = (body == b) & (vol > 0.0) & touching
        if not sel.any():
            continue
        for n, row in zip(normals, rows):
            depth = float((row[0] + skin[sel] - x[sel] @ n).max())
            if shapes[b, 0] > 0.0:   # round 88: its exact sphere's or cylinder's (round_ground), at its rest pose
                c = (m[body == b, None] * x[body == b]).sum(0) / m[body == b].sum()
                depth = shape_depth(c, np.eye(3), shapes[b], n, row[0], band[b])
            if depth > 0.0:
                x[body == b] += depth * n
                moved = True
        for col in cols if shapes[b, 0] > 0.0 else ():   # round 89: and out of the colliders, on its exact shape
            c = (m[body == b, None] * x[body == b]).sum(0) / m[body == b].sum()
            depth, n = round_ground.collider_depth(col, c, np.eye(3), shapes[b], band[b])
            if depth > 0.0:
                x[body == b] += depth * n
                moved = True
    return dataclasses.replace(setup, x=x) if moved else setup


def rigid_affine(setup):
    """The setup with its rigid bodies' given ``C`` (a spin's ``[w]``, ``gasp_core.prepare.assembly.spin``) scaled by
    :data:`APIC_SPIN`: their points carry the share of the spin the engines' projection gives them, so the first
    projection reads the spin given (with ``C = [w]`` and ``APIC_SPIN`` 0 it read ``w (1 + M dx^2 / (2 I))``, 30 %
    more for a ball of 2 cells' radius). ``setup`` itself when there is nothing to scale."""
    C = getattr(setup, "C", None)
    rigid = rigid_mask(setup.materials)
    if C is None or APIC_SPIN == 1.0 or not rigid.any():
        return setup
    rows = rigid[np.asarray(setup.body_id)]
    if not np.any(np.asarray(C)[rows]):
        return setup
    C = np.array(C, copy=True)
    C[rows] *= APIC_SPIN
    return dataclasses.replace(setup, C=C)


def affine_dx(dx: float) -> float:
    """The spacing whose ``M dx^2 / 2`` the engines' rigid laws add to a body's inertia: ``dx sqrt(APIC_SPIN)``
    (``dx`` to round 66, 0 since round 67: :data:`APIC_SPIN`)."""
    return float(dx) * float(np.sqrt(APIC_SPIN))


def affine_spin(C: np.ndarray) -> np.ndarray:
    """``eps : C^T`` per point: ``(C_zy - C_yz, C_xz - C_zx, C_yx - C_xy)`` (shape (n, 3)); APIC's angular momentum
    of a point is ``m x x v + m dx^2 / 4 (eps : C^T)`` (Jiang et al. 2015, ``D = dx^2 / 4 I``)."""
    C = np.asarray(C, dtype=np.float64)
    return np.stack([C[:, 2, 1] - C[:, 1, 2], C[:, 0, 2] - C[:, 2, 0], C[:, 1, 0] - C[:, 0, 1]], axis=1)


def skew(w) -> np.ndarray:
    """The cross-product matrix of ``w`` (shape (3,)): ``skew(w) @ r == cross(w, r)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rigid_project(x: np.ndarray, v: np.ndarray, C: np.ndarray, m: np.ndarray, dx: float, spin: float | None = None,
                  booked=None):
    """Project one body's point velocities onto the rigid motion with the same momentum and angular momentum.

    Parameters
    ----------
    x, v : ndarray, shape (n, 3)
        Positions (m) and velocities (m/s).
    C : ndarray, shape (n, 3, 3)
        APIC affine velocity matrices, 1/s.
    m : ndarray, shape (n,)
        Masses, kg (at least one positive).
    dx : float
        Grid spacing, m (APIC's ``D = dx^2 / 4 I``).
    spin : float, optional
        The share of ``w`` the points carry in their ``C`` (:data:`APIC_SPIN` when None).
    booked : array_like, shape (3,), optional
        The spin (rad/s) the points carried in full into the P2G that gave ``v`` and ``C``
        (``gasp_core.mpm.spin_booking``); its booking beyond the inertia's share, ``(1 - spin) M dx^2 / 2 booked``,
        is taken off ``L`` first. None: nothing is taken off.

    Returns
    -------
    v_new : ndarray, shape (n, 3)
        ``V + w x (x - c)``: ``V = P / M``, ``c`` the centre of mass, ``w = I^-1 L`` with ``L`` the angular
        momentum about ``c`` (points and affine parts) and ``I = sum m (|r|^2 1 - r r^T) + spin M dx^2 / 2 1``
        (the affine parts' inertia: each point's ``D`` adds ``m dx^2 / 2`` per unit of spin it carries).
    C_new : ndarray, shape (n, 3, 3)
        ``spin skew(w)`` on every point.
    w : ndarray, shape (3,)
        Angular velocity, rad/s.

    Notes
    -----
    ``sum m v_new = P`` and ``sum m (x - c) x v_new + m dx^2 / 4 eps : C_new^T = L`` (to rounding).
    """
    x, v, m = (np.asarray(a, dtype=np.float64) for a in (x, v, m))
    spin = APIC_SPIN if spin is None else float(spin)
    M = float(m.sum())
    c = (m[:, None] * x).sum(axis=0) / M
    P = (m[:, None] * v).sum(axis=0)
    r = x - c
    L = (m[:, None] * np.cross(r, v)).sum(axis=0) + 0.25 * dx * dx * (m[:, None] * affine_spin(C)).sum(axis=0)
    if booked is not None:   # what P2G booked beyond the inertia's share (gasp_core.mpm.spin_booking.booked_share)
        L = L - 0.5 * (1.0 - spin) * dx * dx * M * np.asarray(booked, dtype=np.float64)
    inertia = (np.eye(3) * (m * (r * r).sum(axis=1)).sum() - np.einsum("n,ni,nj->ij", m, r, r)
               + np.eye(3) * 0.5 * spin * dx * dx * M)
    w = np.linalg.solve(inertia, L)
    v_new = P / M + np.cross(w, r)
    return v_new, np.broadcast_to(spin * skew(w), (len(x), 3, 3)).copy(), w


def body_frames(x: np.ndarray, m: np.ndarray, body: np.ndarray, rigid: np.ndarray):
    """Each rigid body's rest frame: its centre of mass and its points relative to it.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Positions, m.
    m : ndarray, shape (n,)
        Masses, kg (passive points 0: they ride along).
    body : ndarray, shape (n,), int
    rigid : ndarray, shape (n_bodies,), bool

    Returns
    -------
    centre : ndarray, shape (n_bodies, 3)
        Centre of mass of each rigid body (zeros for the others), m.
    X0 : ndarray, shape (n, 3)
        ``x - centre[body]`` for the points of rigid bodies (zeros for the others), m.
    inertia0 : ndarray, shape (n_bodies, 3, 3)
        ``sum m (|X0|^2 1 - X0 X0^T)`` per rigid body, kg m^2 (without APIC's ``M dx^2 / 2 1``).
    mass : ndarray, shape (n_bodies,)
        kg.
    """
    x, m = np.asarray(x, np.float64), np.asarray(m, np.float64)
    nb = len(rigid)
    centre, inertia0, mass = np.zeros((nb, 3)), np.zeros((nb, 3, 3)), np.zeros(nb)
    X0 = np.zeros_like(x)
    for b in np.flatnonzero(rigid):
        sel = body == b
        mass[b] = m[sel].sum()
        if mass[b] <= 0.0:
            continue
        centre[b] = (m[sel, None] * x[sel]).sum(axis=0) / mass[b]
        r = x[sel] - centre[b]
        X0[sel] = r
        inertia0[b] = np.eye(3) * (m[sel] * (r * r).sum(axis=1)).sum() - np.einsum("n,ni,nj->ij", m[sel], r, r)
    return centre, X0, inertia0, mass
