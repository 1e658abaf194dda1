"""The particle contact of the grid (MPM) engines (engine option ``contact``, ``docs/contact.md``).

``contact = "particle"`` (under the default ``"auto"``: every body whose material does not flow,
:func:`contact_model`; the flowing ones take the grid rule in the same scene, :func:`rule_models`). Each point
carries a contact skin ``s_p = SKIN h_p`` (``h_p = p_vol^(1/3)``, its spacing: the body's surface lies about half a
spacing beyond its outer points). A ground plane at height ``H`` with its normal ``+z`` is in contact with the point when ``depth = H + s_p - z > 0``; in
P2G the point's momentum then gains the normal impulse

    j_n = max(0, dt (k_p depth - c_p v_z)),   k_p = KAPPA E h_p,   c_p = 2 DAMPING sqrt(k_p m_p)

(a damped penalty: ``E`` the body's Young's modulus, ``m_p`` the point's mass), so the grid and the stress
see the contact where the point is. Friction is Coulomb's, at the nodes: P2G also scatters ``mu j_n`` with the
point's weights into a per-node budget ``b_i`` (kg m/s), and the grid update takes ``min(b_i / m_i, |v_t|)``
off the node's tangential velocity ``v_t`` (it can stop the node, never turn it back). The ground's grid nodes
are kept out of the body's reach (the node layers more than ``GRID_LAYERS_BELOW`` cells below the plane: a
safety net for a point driven more than half a cell deep).

``[[collider]]``s (signed distance fields, static or moving) meet the points the same way
(:func:`surface_impulse`): ``depth = s_p - phi`` with ``phi`` the collider's signed distance at the point, the
impulse along its outward normal ``n`` against the velocity relative to the collider's (``v_col``), and the budget
spent on the node's velocity relative to the collider's in the plane normal to ``n``; their grid rule acts only
``GRID_LAYERS_BELOW`` cells inside them (:func:`collider_grid_depth`). ``walls`` too (issue 38 item 2): each face of
the domain box is a plane ``WALL_NODES`` cells inside it (where the grid rule's wall nodes end, ``docs/mpm.md``),
met like the ground's (:func:`contact_planes`: ``depth = offset + s_p - n . x``, friction in the plane normal to
``n``), each its own support of the balance; their grid rule keeps only the nodes more than 1.5 cells behind the
plane (:func:`wall_grid_cells`).

``contact = "grid"``: the ground's, the walls' and the colliders' node layers are projected (the MLS-MPM reference code's "separate" collider,
``docs/mpm.md`` step 3), the rule before issue 28; it spins bouncing soft bodies up and floats resting ones
(``docs/contact.md``).

The grid engine plugins' kernels implement :func:`plane_impulse` step for step.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.options import Option
from gasp_core.mpm.points import ground_top_node, WALL_NODES
from gasp_core.mpm.contact_reference import node_friction, plane_impulse, surface_impulse   # noqa: F401 (re-exported)

#: Contact stiffness per unit Young's modulus and point spacing (dimensionless): ``k_p = KAPPA E p_vol^(1/3)``.
#: Chosen with ``DAMPING`` and ``SKIN`` from the candidates of ``docs/contact.md``
#: (``benchmarks/studies/contact_candidates.py``), then halved from 4 (issue 38): the stiffer the contact, the
#: sharper the impact's waves and the more of them the APIC transfers filter out. ``bounce_hertz`` at cfl 0.1 (22
#: substeps a frame): restitution 0.794 at 4, 0.812 at 2, 0.833 at 1; ``incline_slide`` 0.82 %, 0.95 %, 1.19 % slow
#: (tolerance 1.25 %): 2 is the stiffest that keeps the bounce above 0.8 at every cfl (``tests/test_contact_step.py``).
KAPPA = 2.0
#: Damping ratio of a point's contact oscillator (``c_p = 2 DAMPING sqrt(k_p m_p)``).
DAMPING = 0.5
#: Contact skin per point spacing (``s_p = SKIN p_vol^(1/3)``).
SKIN = 0.5
#: With the particle contact, a ground's grid node layers start this many cells below its top layer.
GRID_LAYERS_BELOW = 2
#: Largest ``omega dt`` of the particle contact (``omega`` in :func:`contact_dt`). An explicit oscillator alone is
#: stable to ``omega dt < 2``; the contact is not alone: on the jelly cube of ``conformance_tests/test_extremes.py``
#: (E 1e5 Pa, dropped at 2 m/s, n_grid 16) the energy rose 16.8 % at ``omega dt`` 1.55 (5 ms steps, ``KAPPA`` 2) and not
#: at 1.03 (3.3 ms); with ``KAPPA`` 4 it rose 239 % at 5 ms and not at 3.3 ms. The limit follows the step (the
#: points cross their skin in a few steps), not ``omega`` alone: ``sqrt(2)`` keeps the step ``KAPPA`` 4 had at 2.
MAX_OMEGA_DT = 2.0 ** 0.5
#: The contact's balance takes back a body's contact torque up to ``J TORQUE_REACH REACH h`` (``J`` the substep's
#: normal impulse, ``h`` the body's median point spacing): the torque of a centre of pressure within a few point
#: spacings of the point below the mass centre, which a handful of irregular points cannot resolve (docs/contact.md).
REACH = 1.0
#: The torque taken back reaches ``TORQUE_REACH`` times that lever; the mass centre may lie ``REACH`` spacings beyond
#: the pushed points' box before the body is left to tip. A ball of points jittered by +-3 mm at n_grid 32 (spacing
#: 5.1 mm) had its centre of pressure up to 6.1 mm off: at 1 spacing, 2.8 % of its impulse kept a lever and it spun
#: up 0.04 rad/s a bounce (travel 5.8 mm); ``tip_over`` (2 spacings beyond its edge) bounds the gate. Since round 86
#: the bound is scaled by the patch's departure from a plane (:mod:`gasp_core.mpm.take_back`): a flat base keeps its
#: torque.
TORQUE_REACH = 2.0
# Of the torque it would take back, the balance keeps the part that brakes the body's horizontal spin, up to stopping
# it (the engines' ``keep_braking``): it takes back what would start a spin, never what stops one (docs/contact.md).
#: Columns of the per-body sums of the contact's balance (the engines' ``balance.py``): mass, its first and second
#: moments, momentum, angular momentum.
SUMS = ("m", "mx", "my", "mz", "mxx", "mxy", "mxz", "myy", "myz", "mzz", "px", "py", "pz", "lx", "ly", "lz")
#: Columns of the per-support sums of the contact's balance (a support: one body against the grounds, or against
#: one collider): the normal impulses' magnitude J, its first moments, the impulse vector ``sum j n``, its moment
#: about the origin ``sum x x j n``, ``sum j v_col`` (the support's velocity at the points), the pushed points' mass
#: ``m`` (round 59: the balance's closing bound) and box; then the impulses' second moments ``sum j x x^T`` and ``sum j^2``
#: (round 86: :mod:`gasp_core.mpm.take_back`).
JSUMS = ("j", "jx", "jy", "jz", "jnx", "jny", "jnz", "mnx", "mny", "mnz", "jvx", "jvy", "jvz", "m",
         "x_min", "x_max", "y_min", "y_max", "z_min", "z_max", "jxx", "jxy", "jxz", "jyy", "jyz", "jzz", "jj")

#: Round 58 (docs/contact.md "Round 58: the sand's base slips at Coulomb's bound"): the contact a sand body takes
#: under ``contact = "auto"``: ``"grid"`` (with snow and liquid, the rule since issue 38) or ``"particle"`` (as the
#: bodies that do not flow). Read by :func:`grid_flows` when a setup is built.
SAND_CONTACT = "grid"
#: The engine option's values.
CONTACT_MODELS = ("auto", "particle", "grid")
#: Materials that flow (granular, fluid): under ``contact = "auto"`` their bodies take the grid contact.
FLOWING = ("sand", "snow", "liquid")
#: docs/contact.md "Round 51" / "Round 52": the grid contact's bound on a touched column's friction (``touch_bound``) ->
#: mode: "credit" round 50's, "debt" the balance signed, a pull's debt paid before more is given; "substep" none
#: carried; "episode" the unused bound too; "body" (default, round 52) the debt's balance per body and ground, pooled.
TOUCH_BOUNDS = {"credit": 0, "debt": 1, "substep": 2, "episode": 3, "body": 4}
#: Round 53, "body"'s ``touch_pull``: "both" (round 52), "contact", "none", "refund" (default; docs/contact.md).
TOUCH_PULLS = {"both": 0, "contact": 1, "none": 2, "refund": 3}
#: Engine option ``contact`` of the MPM engines.
CONTACT = Option("contact", "auto", "ground and collider contact: 'particle' (a penalty and Coulomb friction per "
                 "point; docs/contact.md), 'grid' (their node layers projected; spins bouncing soft bodies up; rigid "
                 "bodies keep the particle contact), each for the whole scene, or 'auto' (chosen per body: grid for "
                 "sand, snow and liquid bodies, particle for the others, in the same scene)", kind="str",
                 choices=CONTACT_MODELS)
#: Engine option ``contact_balance`` of the MPM engines.
BALANCE = Option("contact_balance", True, "the particle contact's balance (docs/contact.md, issue 38): each body's "
                 "net friction is Coulomb's on its rigid motion and the contact torque of a centre of pressure "
                 "within a point spacing of its mass centre is taken back where its pushed points do not lie in a "
                 "plane; false: the raw per-point contact, on which bodies of irregular points turn and roll "
                 "(10-80 mm)", kind="bool")


def contact_model(setup) -> str:
    """The contact a setup runs with: its option ``contact``. ``"particle"`` and ``"grid"`` mean the whole scene.
    ``"auto"`` (the default) is chosen per body (issue 38 item 3, ``docs/contact.md`` "Chosen per body"): a body whose
    material flows (:data:`FLOWING`: the grid contact's spreading of a sand column matches Lube et al. 2005 within
    12 %, the particle contact's within 29 %; round 58, in the conformance column's channel: -20 % and, the walls'
    floor no longer halving the ground's friction (:func:`wall_faces`), -55 %) takes the grid contact, every other body the particle contact (since
    its balance an E 1e6 ball rests within 0.14 mm, a figure on two legs at 1.4e6 Pa stands; on the grid contact the
    ball rolled 74 mm). Returns ``"particle"`` when no body flows, ``"grid"`` when every body does, else ``"mixed"``
    (:func:`flowing_bodies` says which bodies take which). Round 51 (``docs/contact.md`` "Round 51: a rigid body on
    the grid contact"): ``"grid"`` never holds a rigid body (a body without stress does not carry its weight to the
    held nodes: a 7.5 cm cube sank 36.9 mm); it takes the particle contact (``"mixed"``, all rigid ``"particle"``)."""
    c = setup.options.get("contact") or "auto"
    if c == "auto":
        flows = [grid_flows(m) for m in setup.materials]
        return "grid" if flows and all(flows) else "mixed" if any(flows) else "particle"
    rigid = rigid_bodies(setup.materials)
    if c == "grid" and rigid.any():
        return "particle" if rigid.all() else "mixed"
    return c


def grid_flows(material) -> bool:
    """Whether a body of ``material`` takes the grid contact under ``contact = "auto"``: its material flows
    (:data:`FLOWING`), sand only where :data:`SAND_CONTACT` is ``"grid"``."""
    return material.name in FLOWING and not (material.name == "sand" and SAND_CONTACT == "particle")


def flowing_bodies(setup, contact: str | None = None) -> np.ndarray:
    """Which bodies take the grid contact: shape (n_materials,), bool; all with ``"grid"``, none with
    ``"particle"``; with ``"mixed"`` those of a :data:`FLOWING` material, or with the option ``contact = "grid"``
    those not rigid (``contact``: default :func:`contact_model` of ``setup``)."""
    c = contact or contact_model(setup)
    if c == "mixed":
        if explicit_grid(setup):
            return ~rigid_bodies(setup.materials)
        return np.array([grid_flows(m) for m in setup.materials], dtype=bool)
    return np.full(len(setup.materials), c == "grid", dtype=bool)


def rigid_bodies(materials) -> np.ndarray:
    """Per body, ``model == "rigid"`` (shape (n_bodies,), bool; ``gasp_core.mpm.rigid.rigid_mask``)."""
    return np.array([getattr(m, "model", "auto") == "rigid" for m in materials], dtype=bool)


def explicit_grid(setup) -> bool:
    """Whether the option ``contact`` is ``"grid"`` (its rigid bodies take the particle contact: contact_model)."""
    return (getattr(setup, "options", None) or {}).get("contact") == "grid"


def rule_models(contact: str) -> tuple[str, str]:
    """``(reach, full)``: the contacts whose grid-rule node sets (:func:`ground_node_layer`,
    :func:`wall_grid_cells`, :func:`collider_grid_depth`) bound where the boundaries' grid rule acts at all and
    where it acts fully. Equal for ``"particle"`` and ``"grid"``; ``("grid", "particle")`` for ``"mixed"``: there a
    node in the grid contact's set but outside the particle contact's safety net (which the grid contact's set
    holds) gets ``v <- v + f (v_rule - v)``, ``f = m_flow / m`` its mass fraction of flowing bodies (scattered in
    P2G), so a node of sand alone takes the grid contact and one of jelly alone the particle contact."""
    return ("grid", "particle") if contact == "mixed" else (contact, contact)


def contact_coefficients(setup) -> np.ndarray:
    """Per point ``(k_p, c_p, s_p)``: stiffness (N/m), damping (N s/m) and skin (m) of the particle contact.

    Parameters
    ----------
    setup : SimSetup
        ``materials`` (``E``, Pa), ``body_id``, ``p_vol`` (m^3), ``p_mass`` (kg).

    Returns
    -------
    ndarray, shape (n, 3), float64
        ``k_p = KAPPA E h_p``, ``c_p = 2 DAMPING sqrt(k_p m_p)``, ``s_p = SKIN h_p``, ``h_p = p_vol^(1/3)``
        (zeros for passive points, which have no volume). A point that starts closer to a ground, a wall's plane or a
        ``[[collider]]`` (its signed distance at t = 0) than its skin (a body placed standing on it, its splats on
        the surface) gets its starting clearance as its skin, so a body the scene places on a support is not
        pushed up by half a spacing in its first substep. A point that starts behind one (a negative clearance: a
        capture's Gaussian vertex through the pan or the ground, as the kitchen's spinach's, 5.9 dx below its ground)
        gets that clearance as its skin, negative: the support holds it at its starting depth and pushes it only
        deeper than that, where ``k_p depth`` on its starting depth threw it out at about ``depth omega`` in one
        substep (issue 66: the brittle spinach at ``default`` left the grid at frame 1). With the contact chosen per
        body (``"mixed"``) the points
        of the bodies that take the grid contact (:func:`flowing_bodies`) get ``k_p = c_p = 0``: no impulse.
    """
    E = np.array([m.E for m in setup.materials], dtype=np.float64)
    if contact_model(setup) == "mixed":
        E = np.where(flowing_bodies(setup, "mixed"), 0.0, E)
    h = np.cbrt(np.asarray(setup.p_vol, dtype=np.float64))
    k = KAPPA * E[np.asarray(setup.body_id, dtype=np.int64)] * h
    x = np.asarray(setup.x, dtype=np.float64)
    clear = np.full(len(h), np.inf)   # each point's starting clearance from its nearest support (m; < 0: behind it)
    normals, rows = contact_planes(setup, "particle")
    for n, row in zip(normals, rows):   # the grounds' and walls' planes
        clear = np.minimum(clear, x @ n - row[0])
    for col in getattr(setup, "colliders", None) or []:
        clear = np.minimum(clear, col.distance(x, 0.0))
    skin = np.minimum(SKIN * h, np.maximum(clear, 0.0))
    skin = np.where((clear < 0.0) & (h > 0.0), clear, skin)   # behind a support at t = 0: held at that depth
    return np.column_stack([k, 2.0 * DAMPING * np.sqrt(k * np.asarray(setup.p_mass, dtype=np.float64)), skin])


def contact_dt(setup) -> float:
    """The longest substep (s) the particle contact of a setup keeps stable: ``MAX_OMEGA_DT / max omega`` over
    its bodies that take the particle contact (all with ``"particle"``, those that do not flow with ``"mixed"``),
    ``inf`` without a ground, walls or a ``[[collider]]``, or with ``"grid"``.

    ``omega = sqrt(KAPPA E / (rho dx h))`` (rad/s) is a contact patch's frequency: the stiffness
    ``KAPPA E h`` of the ``(dx / h)^2`` points of median spacing ``h`` (m) that press on one node, over the node's
    mass ``rho dx^3``. The grid engines take the shorter of this and the CFL step; a hand-set ``dt`` or
    ``n_substeps`` longer than this is shortened to it with a warning (``gasp_core.mpm.grid_engine.choose_dt``).
    Measured (``conformance_tests/test_extremes.py``, a 0.2 m jelly cube, E 1e5 Pa, dropped at 2 m/s): at ``cfl = 1.0`` (5 ms steps) the contact gained 239 % of the body's energy with ``KAPPA`` 4 and 16.8 % with 2; at 3.3 ms
    none. The README donut (median ``omega dt`` 1.5 at the default ``cfl = 0.4``) is not affected.
    """
    contact = contact_model(setup)
    if contact not in ("particle", "mixed") or not (any(b.kind in ("ground", "walls") for b in setup.boundaries)
                                                    or getattr(setup, "colliders", None)):
        return float("inf")
    h = np.cbrt(np.asarray(setup.p_vol, dtype=np.float64))
    body = np.asarray(setup.body_id, dtype=np.int64)
    omega = 0.0
    grid = flowing_bodies(setup, contact)
    for b, m in enumerate(setup.materials):
        hb = h[(body == b) & (h > 0.0)]
        if len(hb) and not grid[b] and float(m.E) > 0.0 and float(m.rho) > 0.0:
            omega = max(omega, float(np.sqrt(KAPPA * float(m.E) / (float(m.rho) * float(setup.dx) * np.median(hb)))))
    return MAX_OMEGA_DT / omega if omega > 0.0 else float("inf")


def collider_grid_depth(contact: str, dx: float) -> float:
    """How deep (m) inside a ``[[collider]]`` the grid rule starts: at its surface (``phi <= 0``) with ``"grid"``;
    ``GRID_LAYERS_BELOW`` cells inside with ``"particle"``, whose points meet the collider at its surface (the
    ground's :func:`ground_node_layer`, as a safety net; a collider thinner than twice that has none)."""
    return 0.0 if contact == "grid" else GRID_LAYERS_BELOW * float(dx)


def touch_dashpot_speed(setup, damping: float = DAMPING) -> float:
    """Round 48 (docs/contact.md "Round 48: a dashpot above the held layers"): the grid contact's dashpot above a
    ground's held node layers, as a speed (m/s, float): ``2 damping c`` with ``c`` the largest P-wave speed of the
    bodies that do not flow (:data:`FLOWING`; 0.0 without one). The engines damp a node's normal velocity there by
    ``1 / (1 + s dt / dx)`` a substep (``s`` this speed): the particle contact's damping ratio ``damping``
    (:data:`DAMPING`) on the cell's oscillator ``omega = c / dx``, implicit (``c_p dt / m = 2 damping omega dt``).
    Round 49 (docs/contact.md "Round 49"): less what the body's own viscosity ``eta`` already damps of that mode (its
    P-wave viscosity ``2 eta``, the bulk ``2 eta / 3`` plus ``4 eta / 3``: a damping ratio ``eta / (rho c dx)``), per
    body ``2 damping c - 2 eta / (rho dx)``, the largest, at least 0. Round 50 (docs/contact.md "Round 50: one
    dashpot speed"): a rigid body (:func:`rigid_bodies`) counts no speed: its stress is zero (``zero_stress``), so it
    has no cell mode to damp and its ``E`` sets no step (``step_view``). Both grid engines call this one rule.
    ``setup``: ``materials`` (``p_wave_speed`` m/s, ``viscosity`` Pa s, ``rho`` kg/m^3, ``name``, ``model``) and
    ``dx`` (m)."""
    speeds = [2.0 * float(damping) * m.p_wave_speed - 2.0 * m.viscosity / (m.rho * setup.dx)
              for m, r in zip(setup.materials, rigid_bodies(setup.materials)) if m.name not in FLOWING and not r]
    return max(0.0, max(speeds, default=0.0))


def wall_grid_cells(contact: str) -> float:
    """How far (cells) inside the domain's faces the walls' grid rule acts: nodes with ``X_d < lo_d + r dx`` or
    ``X_d > hi_d - r dx`` are wall nodes. The walls' planes lie ``WALL_NODES`` (3, ``docs/mpm.md``) cells inside the
    faces for both contact models. With ``"grid"`` the nodes on a plane and behind it (``WALL_NODES + 0.5``: decided
    half a cell clear of rounding), as the ground's node on its plane is a ground node (:func:`ground_node_layer`):
    the nodes behind the plane alone left the layer on the plane free, and sand pressed on a wall crept a cell past
    its plane (a column in a closed channel 6 cells deep settled 23 times its elastic strain, spreading into the
    walls). With ``"particle"``, whose points meet the planes (:func:`contact_planes`), 1.5: the nodes
    ``GRID_LAYERS_BELOW`` or more cells behind a plane on a domain of whole cells (a safety net)."""
    return WALL_NODES + 0.5 if contact == "grid" else WALL_NODES - GRID_LAYERS_BELOW + 0.5


def wall_floor(setup, contact: str) -> bool:
    """Whether the ``walls``' floor face (``z = lo_z + 3 dx``) acts for the grid rule of ``contact``: not with
    ``"grid"`` in a scene with a ``ground``, whose plane is then the floor (:func:`wall_grid_cells`' node layer on the
    floor's plane would otherwise stand above a ground placed within three cells of the domain's bottom:
    ``examples/donut_shatter.toml``'s ground is 2.1 cells up, under a floor plane 8 mm higher). The particle
    contact keeps the floor's node layers (1.5 cells behind its plane, a safety net) but, with a ground, not its
    plane (:func:`wall_faces`, round 58)."""
    return not (contact == "grid" and any(b.kind == "ground" for b in setup.boundaries))


def wall_faces(setup) -> list[tuple[int, float]]:
    """The faces of a ``walls`` boundary that are planes of the particle contact (:func:`contact_planes`), as ``(axis,
    sign)`` (``+1.0`` the low face, normal ``+e_d``; ``-1.0`` the high face), x, y, z, low before high: all six, less
    the floor (``(2, +1.0)``) in a scene with a ``ground``, whose plane is then the floor, as :func:`wall_floor` says
    for the grid contact. Round 58 (``docs/contact.md`` "Round 58: the walls' floor under a ground"): the floor plane
    ``lo_z + 3 dx`` on (or within a skin of) a ground's plane shared each resting point's push with it, so the
    ground's friction acted on about half the weight (a sand column's ground at ``lo_z + 3 dx``: its friction in
    effect halved); below a ground it held the bodies on a frictionless plane above it."""
    floor = any(b.kind == "ground" for b in setup.boundaries)
    return [(d, sign) for d in range(3) for sign in (1.0, -1.0) if not (floor and d == 2 and sign > 0)]


def contact_planes(setup, contact: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The plane supports of the particle contact: each ``ground``, then each face of each ``walls`` boundary.

    Parameters
    ----------
    setup : SimSetup
        ``boundaries``, ``domain_lo`` / ``domain_hi`` (m), ``dx`` (m), ``colliders``.
    contact : str, optional
        The contact model (default :func:`contact_model` of ``setup``); no planes unless ``"particle"`` or
        ``"mixed"``.

    Returns
    -------
    normals : ndarray, shape (n, 3), float64
        Unit normals into the domain: ``+z`` for a ground; ``+e_d`` / ``-e_d`` for the low / high face on axis ``d``
        (x, y, z; low before high).
    rows : ndarray, shape (n, 3), float64
        ``(offset, friction, support)``: the plane is ``n . x = offset`` (m; a ground's height; a wall's plane (its
        faces :func:`wall_faces`: no floor face where there is a ground) lies
        ``WALL_NODES`` cells inside its face, where the grid rule's wall nodes end: ``lo_d + 3 dx``,
        ``-(hi_d - 3 dx)``), its Coulomb friction, and its row of the contact's balance: 0 for the grounds (one
        support), ``1 + len(colliders) + w`` for the ``w``-th wall face (each its own support, after the colliders').
    """
    if (contact or contact_model(setup)) not in ("particle", "mixed"):
        return np.zeros((0, 3)), np.zeros((0, 3))
    normals, rows = [], []
    n_col = len(getattr(setup, "colliders", None) or [])
    lo, hi = np.asarray(setup.domain_lo, np.float64), np.asarray(setup.domain_hi, np.float64)
    inset = WALL_NODES * float(setup.dx)
    for b in setup.boundaries:
        if b.kind == "ground":
            normals.append((0.0, 0.0, 1.0))
            rows.append((float(b.height), float(b.friction), 0.0))
    n_ground = len(rows)
    for b in setup.boundaries:
        if b.kind == "walls":
            for d, sign in wall_faces(setup):
                offset = lo[d] + inset if sign > 0 else -(hi[d] - inset)
                normals.append(tuple(sign if q == d else 0.0 for q in range(3)))
                rows.append((float(offset), float(b.friction), float(1 + n_col + len(rows) - n_ground)))
    return np.array(normals, np.float64).reshape(-1, 3), np.array(rows, np.float64).reshape(-1, 3)


def ground_node_layer(contact: str, height: float, domain_lo_z: float, dx: float) -> int:
    """The highest node layer the ground projects: :func:`ground_top_node` for ``"grid"``, ``GRID_LAYERS_BELOW``
    lower for ``"particle"``."""
    top = ground_top_node(height, domain_lo_z, dx)
    return top if contact == "grid" else top - GRID_LAYERS_BELOW


#: Round 59 (docs/contact.md "Round 59: the balance on a flowing body"): whether the contact's balance acts on a body
#: whose material flows (:data:`FLOWING`). False (the rule): it does not; True restores the rule before round 59
#: (a probe, and the catch of ``tests/test_flow_balance.py``). Read by :func:`balance_mass` when an engine is built.
BALANCE_FLOWING = False


def balance_mass(setup) -> np.ndarray:
    """Per body, the mass (kg) the contact's balance reads for its Coulomb target (``m`` of ``min(mu J, m |u_t|)``);
    0 switches the balance off for that body (the engines' ``body_fix`` acts only where it is positive). Shape
    (n_materials,), float64.

    Round 59 (docs/contact.md "Round 59: the balance on a flowing body"): a body whose material flows
    (:data:`FLOWING`: sand, snow, liquid) gets 0 unless :data:`BALANCE_FLOWING`. The balance makes a body's net
    friction Coulomb's on its rigid motion (its mean velocity and spin at the centre of pressure) with the budget of
    all its contact points; a flowing body has no rigid motion: in a collapsing sand column the part under the column
    stands still while the front slides, and the balance gave the front the standing part's unused budget (the
    column at a = 2, n_grid 32, particle contact: runout -58.4 % against Lube with it, -47.7 % without it; a
    thrown sand block beside a resting one of the same body stops short of Coulomb's travel). Its friction is then
    each node's own Coulomb bound (``mu`` times the normal impulse its points took), as for the grid contact."""
    body = np.asarray(setup.body_id, dtype=np.int64)
    mass = np.bincount(body, weights=np.asarray(setup.p_mass, dtype=np.float64), minlength=len(setup.materials))
    mass = mass[:len(setup.materials)].astype(np.float64)
    if not BALANCE_FLOWING:
        flows = np.array([m.name in FLOWING for m in setup.materials], dtype=bool)
        mass[flows] = 0.0
    return mass


def contact_reach(setup) -> np.ndarray:
    """Per body, the lever (m) up to which the contact's balance takes its contact torque back: ``REACH`` times the
    median spacing ``p_vol^(1/3)`` of its points (0 for a body without volume). Shape (n_materials,), float64;
    empty (no balance) with the option ``contact_balance = false``."""
    if not setup.options.get("contact_balance", True):
        return np.zeros(0)
    h = np.cbrt(np.asarray(setup.p_vol, dtype=np.float64))
    body = np.asarray(setup.body_id, dtype=np.int64)
    out = np.zeros(len(setup.materials))
    for b in range(len(out)):
        hb = h[(body == b) & (h > 0.0)]
        out[b] = REACH * float(np.median(hb)) if len(hb) else 0.0
    return out
