"""Round 66 (issue 67 items 2 and 4, ``docs/rigid.md`` "Round 66: the point contact on a ball"): the rigid collider's
contact of the soft body's *points* against the rigid body's *shape*, instead of round 63's node band.

Why (round 65, measured): the band takes the soft field's normal at every band node up to 1.4 cells from the
contact, so a ball rolling on a jelly slab (a 6 mm contact patch at dx 15 mm) reads its descending front as an
approach: a frictionless contact stopped its spin in 0.03 s, with friction it stopped. A node band cannot resolve the
patch; the soft body's points (spacing dx / 2) against the body's own surface can.

**The shape** (:func:`body_sdf`, once per rigid body, at rest, in its body frame; any shape: a block, a ball, a plate,
a ring, a scan): the body's points (offsets from its centre) each fill a cube of their spacing ``s`` (the median
nearest-neighbour distance); that occupancy on a lattice of ``h = s / LATTICE`` is blurred by a Gaussian of
``BLUR s`` (which rounds the points' staircase and a lattice ball's ragged outer layer) and cut at 1/2 (a face's
surface half a spacing, a quarter cell, beyond its outer points: where the collider and the
ground's law put it); the signed distance to that cut (Euclid's transform, ``scipy.ndimage``; the half-voxel
offsets taken off), smoothed by a quarter spacing, and its gradient on the same lattice. Read trilinearly
(:func:`sdf_read`); outside the lattice (:data:`PAD` cells beyond the points) no contact.

**The contact** (per substep, after the grid update and round 63's ``V*``, before G2P; :data:`POINT_CONTACT`): a
soft point at its position after the substep (its G2P velocity read from its field) touches a slot's body where its
body-frame distance ``phi < SKIN`` cells (the soft point's own half spacing), the body at ``V*`` with its spin, its
centre moved by ``dt V*``. The touching points that approach it (``u . n < b``, ``u = v - V* - w x r``, ``b =
BIAS (SKIN dx - phi) / dt`` Baumgarte's way out of a penetration) and the body are solved as round 63's band nodes
are (:func:`gasp_core.mpm.rigid_collider.collide` with the points for the nodes: the 6 x 6 normal solve, the
tangential one, Coulomb's cap per pair with ``combine_friction``'s ``mu``); each point's change of momentum goes to
its field's nodes by its weights (so G2P gives it, and its gradient to ``F``), the body takes the opposite into its
projection sums. Only round bodies (:func:`round_body`) take it; bodies with faces keep round 63's node band.
Measured and the variants tried: ``docs/rigid.md`` "Round 66: the point contact on a ball".

Round 67 (:data:`GRID_PASSES` > 0): the same contact as a constraint of the grid velocities (Jacobi passes of
gather, residual and scatter over the touching points, each step over a row-sum bound of the response), so after
G2P a touching point does not approach (round 66's contact per point let a soft body creep through a ball under it);
:data:`PATCH` reads each soft point as its patch of the soft body's surface, :data:`STIFFNESS` gives it a compliance.
Measured: ``docs/rigid.md`` "Round 67: the point contact as a constraint of the grid".

Round 70: the engine option ``roll_contact`` (:mod:`gasp_core.mpm.roll_contact`) turns this contact on for round
bodies with a sphere's exact shape (``point_data``'s ``sphere``), the patches, and friction one impulse a patch.
"""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.roll_contact import point_spacing, round_body   # noqa: F401 (round 88: moved there, re-exported)

#: Round 66: True takes the rigid collider's contact by the soft points against the body's shape (module notes);
#: False: round 63's node band (a ball rolling on jelly lost its spin in 0.03 s, ``docs/rigid.md`` "Round 65").
POINT_CONTACT = False
#: A soft point touches where the body's distance at it is below this many cells (its own half spacing, dx / 4).
SKIN = 0.25
#: Lattice voxels per point spacing (fewer where the lattice would pass :data:`MAX_VOXELS`).
LATTICE = 8
MAX_VOXELS = 4_000_000
#: The blur of the points' occupancy, in point spacings (a 3 cm lattice ball at n_grid 32: 0.5 left the normals 9 deg
#: off the radial on average, 0.75 3 deg; the ball rolling on jelly at n_grid 48 (frictionless, 0.2 s, the normals
#: smoothed by 2 spacings): 0.75 v -9 %, w R -6 %; 1.0 -6 %, -2.5 %; 1.25 -3.9 %, -0.9 %, its centre 1.5 mm lower.
#: A face stays where it was (the cut at 1/2 of a symmetric blur); edges and corners round by about this much).
BLUR = 1.25
#: The distance's own smoothing, in point spacings.
SMOOTH = 0.25
#: The normals' smoothing, in point spacings: the gradient of the distance smoothed this much more (a lattice ball's
#: normals otherwise off the radial by 3 deg on average, whose moments turned a frictionless ball: measured, n_grid 48,
#: R 3 cm: w R -19 % in 0.2 s with 0.25, the exact sphere's distance 0.0 %; a smoothing of the distance itself by 2
#: spacings shrank the ball by 3.4 mm).
NORMAL_SMOOTH = 2.0
#: 1: the blur's shrink of a curved surface taken back (``sigma^2`` times the mean curvature of the smoothed normals:
#: a 3 cm lattice ball's contact radius 27.1 -> 30 mm at n_grid 32); 0 (the default): kept. Measured (rolling on jelly,
#: 0.2 s, n_grid 32, R 3 cm): with it the ball sits where its points put it (rise +0.6 mm against -2.9) but keeps its
#: spin worse (frictionless w R -8.6 % against -2.2 %; mu 0.5 -18 % against -6.6 %).
CURVATURE = 0
#: The lattice reaches this many cells beyond the body's points.
PAD = 1.0
#: Deliberately broken variants for the checks: FRICTION_CAP 0 drops the Coulomb cap (the tangential change applied
#: whole); REACT_POINTS 0 gives the body no reaction.
FRICTION_CAP = 1
#: The penetration's way out: a point ``SKIN - phi`` inside leaves at ``BIAS (SKIN - phi) / dt`` (Baumgarte's; without
#: it the contact is a dashpot: a ball at rest on jelly sank 14 mm in 0.25 s at a steady 3 cm/s).
BIAS = 0.5
REACT_POINTS = 1
#: Round 67: the contact as a constraint of the grid velocities (``docs/rigid.md`` "Round 67"): this many Jacobi
#: passes of gather (each touching point's velocity from its nodes), residual (its approach left) and scatter (its
#: impulse's step to its nodes, the opposite to the body) per substep; 0: round 66's contact per point (the default:
#: the grid's constraint holds a soft body on a ball but rolls worse, ``docs/rigid.md``).
GRID_PASSES = 0
#: Round 67: each soft point's own stiffness in the contact, ``k = STIFFNESS E s`` (``s = dx / 2`` its spacing, ``E``
#: its body's Young's modulus: the sub-grid compliance of its cube of material); 0: a hard contact.
STIFFNESS = 0.0
#: Round 67 (trial): each soft point read as its patch of the soft body's surface, half-size PATCH cells (0: a point).
PATCH = 0.0
#: A broken variant: SOFT_SIDE 0 drops the soft points' change (the body alone takes the contact; the bug merged
#: first in round 66: the nodes' masses read after the grid update had cleared them). 1: each field's node mass kept
#: before the clear (``pc_m``).
SOFT_SIDE = 1


def body_sdf(X0: np.ndarray, dx: float) -> dict:
    """The signed distance of a rigid body's shape from its points ``X0`` ((N, 3) m, offsets in its rest frame):
    ``{"origin": (3,) m, "h": m, "phi": (nx, ny, nz) m (negative inside), "grad": (nx, ny, nz, 3)}``."""
    from scipy import ndimage
    from scipy.spatial import cKDTree
    X0 = np.asarray(X0, float)
    s = point_spacing(X0)
    span = X0.max(0) - X0.min(0) + 2 * PAD * dx + 4 * s / LATTICE
    h = max(s / LATTICE, float(np.prod(span) / MAX_VOXELS) ** (1.0 / 3.0))
    lo = X0.min(0) - PAD * dx - 2 * h
    hi = X0.max(0) + PAD * dx + 2 * h
    dims = np.ceil((hi - lo) / h).astype(int) + 1
    axes = [lo[a] + h * np.arange(dims[a]) for a in range(3)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    d, _ = cKDTree(X0).query(g, p=np.inf, distance_upper_bound=s)
    occ = (d <= 0.5 * s).reshape(dims).astype(float)
    inside = ndimage.gaussian_filter(occ, BLUR * s / h, mode="constant") >= 0.5
    phi = np.where(inside, -(ndimage.distance_transform_edt(inside) - 0.5),
                   ndimage.distance_transform_edt(~inside) - 0.5) * h
    grad = np.stack(np.gradient(ndimage.gaussian_filter(phi, NORMAL_SMOOTH * s / h, mode="nearest"), h), -1)
    phi = ndimage.gaussian_filter(phi, SMOOTH * s / h, mode="nearest")
    if CURVATURE:   # the blur's shrink of a curved surface, sigma^2 times its mean curvature: a ball's sigma^2 / R
        nrm = grad / np.maximum(np.linalg.norm(grad, axis=-1, keepdims=True), 1e-12)
        div = sum(np.gradient(nrm[..., a], h, axis=a) for a in range(3))
        phi = phi - 0.5 * (BLUR * s) ** 2 * div
    return {"origin": lo, "h": h, "phi": phi, "grad": grad}


def sdf_read(sdf: dict, q: np.ndarray) -> tuple[float, np.ndarray]:
    """``(phi, grad)`` of :func:`body_sdf`'s field at body-frame ``q`` (3,) m, trilinear; ``(inf, 0)`` outside."""
    phi, grad = sdf["phi"], sdf["grad"]
    f = (np.asarray(q, float) - sdf["origin"]) / sdf["h"]
    i = np.floor(f).astype(int)
    if np.any(i < 0) or np.any(i >= np.array(phi.shape) - 1):
        return np.inf, np.zeros(3)
    t = f - i
    p, gr = 0.0, np.zeros(3)
    for a in (0, 1):
        for b in (0, 1):
            for c in (0, 1):
                w = (t[0] if a else 1 - t[0]) * (t[1] if b else 1 - t[1]) * (t[2] if c else 1 - t[2])
                p += w * phi[i[0] + a, i[1] + b, i[2] + c]
                gr += w * grad[i[0] + a, i[1] + b, i[2] + c]
    return float(p), gr


def point_contact(M, inertia, V, w, centre, rot, sdf, dx, x, v, m, mu, dt=None):
    """The reference of one substep's point contact (module notes) for one rigid body (mass ``M``, ``inertia``
    (3, 3) about its centre, ``V``, ``w``, ``centre`` (3,), ``rot`` (3, 3)) and soft points at ``x`` with velocities
    ``v`` (N, 3), masses ``m`` (N,): ``(dv, J, L)`` as :func:`gasp_core.mpm.rigid_collider.collide` (the points for
    the nodes). ``dt`` (s): the penetration's way out (:data:`BIAS`) taken as a normal velocity the point leaves at
    (the approach measured against it: ``collide`` with ``v - b n``); None: none."""
    from gasp_core.mpm.rigid_collider import collide
    x, v = np.asarray(x, float), np.asarray(v, float)
    n = np.zeros_like(x)
    b = np.zeros(len(x))
    touch = np.zeros(len(x), bool)
    for p in range(len(x)):
        phi, g = sdf_read(sdf, np.asarray(rot).T @ (x[p] - centre))
        if phi < SKIN * dx and np.linalg.norm(g) > 0:
            touch[p], n[p] = True, np.asarray(rot) @ g / np.linalg.norm(g)
            b[p] = 0.0 if dt is None else BIAS * (SKIN * dx - phi) / dt
    dv = np.zeros_like(v)
    if not touch.any():
        return dv, np.zeros(3), np.zeros(3)
    vs = v[touch] - b[touch, None] * n[touch]
    d, J, L = collide(M, inertia, V, w, np.asarray(m, float)[touch], x[touch] - centre, vs, n[touch], mu)
    dv[touch] = d
    return dv, J, L


def point_data(setup, bodies) -> dict:
    """What an engine's point contact reads for the collider's slots (``bodies``, their rigid bodies): ``{"on":
    (n_slots,) int32 (1: a round body, :func:`round_body`), "phi": float32 (all slots' lattices, flat), "grad":
    (n, 3) float32, "origin": (n_slots, 3), "h": (n_slots,), "dims": (4 n_slots,) int32 (each slot's shape and its
    first voxel), "comp": (n_bodies,) float64 (round 67: each body's points' compliance, m/N, :data:`STIFFNESS`),
    "sphere": (n_slots,) float64 (round 70, the option ``roll_contact``: a sphere's exact radius, m; 0: its lattice),
    "cylinder": (n_slots, 5) float64 (round 72: a solid cylinder's radius, half-length, rest-frame axis; 0s: none),
    "roll": 1 where the option is on}``;
    a body with faces a one-voxel lattice (no contact), and a sphere too. All off without :data:`POINT_CONTACT` or
    ``roll_contact``."""
    from gasp_core.mpm.rigid import body_frames, rigid_mask
    import gasp_core.mpm.roll_contact as roll
    rolls = roll.on(setup)   # round 70: the option roll_contact (its round spheres exact: "sphere", m; 0 none)
    bodies = np.asarray(bodies, int)
    body = np.asarray(setup.body_id)
    mass = np.broadcast_to(np.asarray(setup.p_mass, np.float64), body.shape)
    X0 = body_frames(setup.x, mass, body, np.asarray(rigid_mask(setup.materials), bool))[1]
    dx = float((np.asarray(setup.domain_hi, float) - np.asarray(setup.domain_lo, float))[0] / setup.n_grid)
    vol = np.broadcast_to(np.asarray(setup.p_vol, np.float64), body.shape)
    out = {"on": np.zeros(len(bodies), np.int32), "phi": [], "grad": [], "origin": [], "h": [], "dims": []}
    sphere = np.zeros(len(bodies), np.float64)
    cyl = np.zeros((len(bodies), 5), np.float64)   # round 72: a cylinder's [R, h, axis in its rest frame]; R 0 none
    base = 0
    for i, k in enumerate(bodies):
        sel = (body == k) & (mass > 0)
        pts = X0[sel]
        on = (bool(POINT_CONTACT) or rolls) and round_body(pts)
        if on and rolls and roll.EXACT:
            sphere[i] = roll.sphere_radius(pts, float(vol[sel].sum()), point_spacing(pts))
        if rolls and roll.EXACT and roll.CYLINDER and not POINT_CONTACT and not sphere[i] and len(pts) >= 8:
            cyl[i] = roll.cylinder_shape(pts, float(vol[sel].sum()), point_spacing(pts))   # round 72 (faces: no
            on = on or bool(cyl[i, 0] > 0.0)                                                # round_body)
        if on and rolls and not POINT_CONTACT and roll.EXACT and not sphere[i] and not cyl[i, 0] and roll.FALLBACK:
            on = False   # round 71: a round body not a sphere takes the default (round 63's band), not the lattice
        out["on"][i] = int(on)
        sdf = body_sdf(pts, dx) if on and not sphere[i] and not cyl[i, 0] else {"origin": np.zeros(3), "h": 1.0, "phi": np.ones((1, 1, 1)),
                                             "grad": np.zeros((1, 1, 1, 3))}
        out["phi"].append(sdf["phi"].reshape(-1))
        out["grad"].append(sdf["grad"].reshape(-1, 3))
        out["origin"].append(sdf["origin"])
        out["h"].append(sdf["h"])
        out["dims"] += [*sdf["phi"].shape, base]
        base += sdf["phi"].size
    # round 67: each body's points' compliance 1 / (STIFFNESS E dx / 2) (0: a hard contact); round 70: the option's own
    k = float(roll.STIFFNESS if rolls else STIFFNESS)
    comp = np.asarray([0.0 if k <= 0.0 or m.model == "rigid" else 1.0 / (k * float(m.E) * 0.5 * dx)
                       for m in setup.materials], np.float64)
    return {"comp": comp, "on": out["on"], "sphere": sphere, "cylinder": cyl, "roll": int(rolls), "phi": np.concatenate(out["phi"]).astype(np.float32),
            "grad": np.concatenate(out["grad"]).astype(np.float32), "origin": np.asarray(out["origin"], np.float64),
            "h": np.asarray(out["h"], np.float64), "dims": np.asarray(out["dims"], np.int32)}
