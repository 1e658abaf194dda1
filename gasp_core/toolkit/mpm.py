"""The optional MPM toolkit: what every grid (MPM) engine of GASP shares, and nothing the seam needs.

Engines opt in by importing it; :mod:`gasp_core.seam.engine` never does. So that with the same scene
every MPM engine starts from the same numbers, it holds:

- the declared options of a grid engine (:func:`mpm_options`, :data:`MPM_OPTIONS`; ``dt`` excludes
  ``n_substeps``, as data: the core checks them);
- the stable time step and substeps (:func:`mpm_stable_dt`, :func:`mpm_substeps`; ``docs/mpm.md``,
  "Time step");
- the material codes and the per-body parameter table the kernels read (:data:`MATERIAL_CODES`,
  ``P_*`` columns, :func:`material_table`) and the initial ``Jp`` (:func:`initial_Jp`);
- the points held by ``fixed_region`` boundaries (:func:`fixed_mask`) and the order of points by
  grid cell (:func:`cell_order`);
- the ``gasp bench`` sweep of a grid engine (:func:`mpm_sweep`, :func:`grid_sweep`).

Material parameters are checked once, by one rule (:data:`gasp_core.seam.setup.MATERIAL_RANGES`, applied by
the scene reader and :class:`~gasp_core.seam.setup.SimSetup`; ``-1 < nu < 0.5``): every model of ``docs/mpm.md`` is well posed on that whole range
(``lam + 2 mu``, ``3 lam + 2 mu`` and the bulk modulus ``K`` stay positive), so an MPM engine adds
no rule of its own on ``nu``.
"""
from __future__ import annotations

import itertools
import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from gasp_core.seam.engine import Option
from gasp_core.errors import SceneError
from gasp_core.seam.setup import Boundary, Material


def p_wave_speed(m: Material) -> float:
    """Dilatational (P-wave) speed ``sqrt((lam + 2 mu) / rho)``, m/s.

    For ``liquid`` the shear modulus is not used: ``sqrt(lam' / rho)`` with the bulk modulus
    ``K`` (:attr:`Material.K`).
    """
    if m.name == "liquid":
        return math.sqrt(m.K / m.rho)
    if m.name == "snow":  # hardening can stiffen the material up to exp(xi * theta_c) (Jp < 1)
        h = math.exp(m.hardening * m.theta_c)
        return math.sqrt(h * (m.lam + 2.0 * m.mu) / m.rho)
    return math.sqrt((m.lam + 2.0 * m.mu) / m.rho)


def mpm_stable_dt(materials: Iterable[Material], dx: float, gravity, height: float,
                  v0_max: float = 0.0, cfl: float = 0.4) -> float:
    """Largest substep that satisfies the elastic-wave and particle CFL limits.

    ``dt = cfl * dx / max(c_p, v_max)`` where ``c_p`` is the fastest P-wave speed over the
    materials and ``v_max = v0_max + sqrt(2 |g| height)`` bounds the speed a falling body reaches
    in the domain.

    Parameters
    ----------
    materials : iterable of Material
    dx : float
        Grid spacing, metres.
    gravity : array-like, shape (3,)
        m/s^2.
    height : float
        Vertical extent of the domain, metres.
    v0_max : float
        Largest initial speed, m/s.
    cfl : float
        Courant number in (0, 1].

    Returns
    -------
    float
        Seconds.

    Notes
    -----
    Fang et al. 2018 / taichi_elements use ``dt <= C dx / c_p`` with ``C`` about 0.3-0.5 for
    explicit MLS-MPM with quadratic B-splines.
    """
    c = max(p_wave_speed(m) for m in materials)
    g = float(np.linalg.norm(gravity))
    v_max = v0_max + math.sqrt(2.0 * g * max(height, 0.0))
    return cfl * dx / max(c, v_max, 1e-12)


def mpm_substeps(setup, dt: float | None = None, n_substeps: int | None = None,
                 cfl: float = 0.4) -> tuple[int, float]:
    """Substeps per frame and substep length for a grid engine (``docs/mpm.md``, "Time step").

    Parameters
    ----------
    setup : SimSetup
    dt : float, optional
        Requested substep, seconds (engine option ``dt``).
    n_substeps : int, optional
        Requested substeps per frame (engine option ``n_substeps``).
    cfl : float
        Courant number for :func:`mpm_stable_dt` when neither is given.

    Returns
    -------
    n_substeps : int
    dt : float
        Seconds, ``setup.frame_dt / n_substeps``.
    """
    if dt is not None:
        dt_max = float(dt)
    elif n_substeps is not None:
        dt_max = setup.frame_dt / int(n_substeps)
    else:
        v0 = float(np.max(np.linalg.norm(setup.v, axis=1))) if len(setup.v) else 0.0
        dt_max = mpm_stable_dt(setup.materials, setup.dx, setup.gravity,
                               height=float(setup.domain_hi[2] - setup.domain_lo[2]), v0_max=v0,
                               cfl=float(cfl))
    return substeps_for(setup.frame_dt, dt_max)


def substeps_for(frame_dt: float, dt_max: float) -> tuple[int, float]:
    """Whole substeps per frame: ``n_substeps = ceil(frame_dt / dt_max)``, ``dt = frame_dt / n_substeps``."""
    n = max(1, math.ceil(frame_dt / dt_max - 1e-9))
    return n, frame_dt / n



#: Default bound on substeps per frame (engine option ``max_substeps``): the README donut needs 122.
MAX_SUBSTEPS = 20_000


def substeps_from_options(setup, options: Mapping[str, Any], engine: str = "") -> tuple[int, float]:
    """:func:`mpm_substeps` with the engine options ``dt``, ``n_substeps``, ``cfl`` and ``max_substeps``.

    Raises
    ------
    SceneError
        More substeps per frame than ``max_substeps`` (default :data:`MAX_SUBSTEPS`): the message
        gives the count, what drives it (the stiffest material's wave speed, the fall speed or
        ``frame_dt``) and how to raise the bound, instead of a run that never finishes a frame.
    """
    n, dt = mpm_substeps(setup, options.get("dt"), options.get("n_substeps"), options.get("cfl", 0.4))
    bound = options.get("max_substeps") or MAX_SUBSTEPS
    if n > bound:
        c = max(p_wave_speed(m) for m in setup.materials)
        raise SceneError(
            f"engine '{engine}': {n:.3g} substeps per frame (dt = {dt:.3g} s for frame_dt = {setup.frame_dt:g} s; "
            f"fastest wave {c:.3g} m/s, dx = {setup.dx:.3g} m) exceeds max_substeps = {bound}: lower E, frame_dt, "
            f"the speeds or n_grid, or raise the engine option max_substeps")
    return n, dt


#: Option of the grid engines with the feature ``passive_points`` (:func:`passive_schedule`).
PASSIVE_EVERY = Option(
    "passive_every", 1, "move passive points every this many substeps, by the grid velocity interpolated "
    "linearly in time between updates (1: every substep, plain G2P)", kind="int", lo=1, hi=MAX_SUBSTEPS)


def passive_schedule(n_substeps: int, every: int, dt: float) -> list[tuple[int, float, float]]:
    """When a frame moves its passive points, and with which weights.

    A passive point is carried by the grid velocity: with an update after every substep ``s``,
    ``x += dt v_s`` (``v_s`` gathered at the point after the grid update of substep ``s``). Gathering
    only every ``m`` substeps, the velocity between two gathers ``v_prev`` (substep ``s - m``, the
    point's stored ``v``) and ``v_now`` (substep ``s``) is taken linear in the substep, which sums to

        ``x += a v_prev + b v_now``,  ``a = dt (m - 1) / 2``,  ``b = dt (m + 1) / 2``

    (``m = 1`` is the plain update: ``a = 0``, ``b = dt``). The error is second order in ``m dt``
    where the grid velocity changes smoothly, and nothing crosses a frame: the last substep of every
    frame updates, so frames are written and saved states resumed with every point in place.

    Parameters
    ----------
    n_substeps : int
        Substeps per frame (>= 1).
    every : int
        ``m``, the engine option ``passive_every`` (>= 1); cut to ``n_substeps``.
    dt : float
        Substep length, s.

    Returns
    -------
    list of (int, float, float)
        ``(s, a, b)`` per update: after the grid update of substep ``s`` (0-based), move by
        ``a v_prev + b v_now`` (metres per m/s). At most two distinct ``(a, b)`` pairs occur.
    """
    every = max(1, min(int(every), int(n_substeps)))
    out, last = [], -1
    for s in range(n_substeps):
        if (s + 1) % every == 0 or s == n_substeps - 1:
            m = s - last
            out.append((s, dt * (m - 1) / 2.0, dt * (m + 1) / 2.0))
            last = s
    return out


def estimate_bytes(n_points: int, n_grid: int, precision: str, grid_copies: int = 1) -> int:
    """Memory an MLS-MPM engine allocates, bytes: particles (x, v, F, C, Jp, mass, volume, ids) and grid.

    ``grid_copies`` counts private grid copies (one per CPU thread where an engine keeps them).
    """
    b = 4 if precision == "f32" else 8
    particles = n_points * (3 + 3 + 9 + 9 + 1 + 1 + 1) * b + n_points * 3 * 4
    grid = (n_grid + 3) ** 3 * 4 * b * (1 + grid_copies)
    return int(particles + grid)


def check_memory(need: int, engine: str, what: str = "") -> None:
    """Refuse before allocating when ``need`` bytes exceed 80 % of this machine's physical memory.

    Raises
    ------
    SceneError
        Naming the estimate, the memory here and the settings that drive it.
    """
    import os
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return
    if need > 0.8 * total:
        raise SceneError(f"engine '{engine}': needs about {need / 2**30:.1f} GiB ({what}); this machine has "
                         f"{total / 2**30:.1f} GiB: lower n_grid or the number of points")


# --------------------------------------------------------------------------- options
def mpm_options(*extra: Option, cuda_index: bool = False) -> tuple[Option, ...]:
    """The options of a grid engine: ``device``, ``precision``, ``dt``, ``n_substeps``, ``cfl``, then ``extra``.

    Parameters
    ----------
    *extra : Option
        The engine's own options (e.g. a CPU thread count).
    cuda_index : bool
        True when the engine can run on a chosen GPU: ``device`` then also takes ``"cuda:N"``.
        False for an engine that only runs on the default CUDA device (``"cpu"`` or ``"cuda"``).

    Returns
    -------
    tuple of Option
        For :attr:`gasp_core.seam.engine.EngineInfo.options`.
    """
    if cuda_index:
        device = Option("device", "cpu", "where to run: 'cpu', 'cuda' (the default GPU) or 'cuda:N' (GPU N)",
                        kind="str", pattern=r"cpu|cuda(:\d+)?")
    else:
        device = Option("device", "cpu", "where to run: 'cpu' or 'cuda' (the default GPU)", kind="str",
                        choices=("cpu", "cuda"))
    return (
        device,
        Option("precision", "f32", "floating-point precision of the solver", kind="str", choices=("f32", "f64")),
        Option("dt", None, "substep length, s (default: from cfl); not with n_substeps", kind="number",
               lo=0.0, lo_open=True, excludes=("n_substeps",)),
        Option("n_substeps", None, "substeps per frame (default: from cfl); not with dt", kind="int", lo=1),
        Option("cfl", 0.4, "Courant number of the automatic substep: dt = cfl dx / max(c_p, v_max)",
               kind="number", lo=0.0, hi=1.0, lo_open=True),
        Option("max_substeps", MAX_SUBSTEPS, "refuse a scene needing more substeps per frame than this "
               "(bounds the work a bad value can ask for)", kind="int", lo=1),
    ) + tuple(extra)


#: The options every MPM engine of this project takes (``docs/mpm.md``), ``device`` "cpu" or "cuda".
MPM_OPTIONS = mpm_options()


# --------------------------------------------------------------------------- materials
#: Material codes of the kernels (index of the branch in the constitutive update).
JELLY, NEO_HOOKEAN, METAL, SAND, SNOW, PLASTICINE, LIQUID = range(7)
MATERIAL_CODES = {"jelly": JELLY, "neo_hookean": NEO_HOOKEAN, "metal": METAL, "sand": SAND, "snow": SNOW,
                  "plasticine": PLASTICINE, "liquid": LIQUID}
#: Columns of the per-body parameter table (:func:`material_table`).
P_MU, P_LAM, P_YIELD, P_SOFTENING, P_HARDENING, P_THETA_C, P_THETA_S, P_ALPHA, P_K = range(9)
N_PARAMS = 9


def material_table(materials: Sequence[Material]) -> tuple[np.ndarray, np.ndarray]:
    """Material code and parameter row of each body, as the kernels read them.

    Parameters
    ----------
    materials : sequence of Material
        One per body; names in :data:`MATERIAL_CODES`.

    Returns
    -------
    kinds : ndarray, shape (n_bodies,), int32
        :data:`MATERIAL_CODES` value of each body.
    params : ndarray, shape (n_bodies, N_PARAMS), float64
        Columns ``P_MU`` (Lame mu, Pa), ``P_LAM`` (Lame lam, Pa), ``P_YIELD`` (von Mises yield
        stress, Pa), ``P_SOFTENING``, ``P_HARDENING`` (snow xi), ``P_THETA_C``, ``P_THETA_S``,
        ``P_ALPHA`` (Drucker-Prager ``alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi))`` of the
        friction angle phi, Klar et al. 2016 Eq. 27) and ``P_K`` (bulk modulus
        :attr:`Material.K`, Pa, of the liquid's equation of state).

    Raises
    ------
    SceneError
        A material without an MPM model here (``rigid``); the engine's capabilities normally
        refuse it before.
    """
    kinds = np.zeros(len(materials), dtype=np.int32)
    params = np.zeros((len(materials), N_PARAMS), dtype=np.float64)
    for b, m in enumerate(materials):
        if m.name not in MATERIAL_CODES:
            raise SceneError(f"material '{m.name}' (body {b}) has no MPM model; MPM materials: "
                             f"{sorted(MATERIAL_CODES)}")
        kinds[b] = MATERIAL_CODES[m.name]
        s = math.sin(math.radians(m.friction_angle))
        params[b, P_MU] = m.mu
        params[b, P_LAM] = m.lam
        params[b, P_YIELD] = m.yield_stress
        params[b, P_SOFTENING] = m.softening
        params[b, P_HARDENING] = m.hardening
        params[b, P_THETA_C] = m.theta_c
        params[b, P_THETA_S] = m.theta_s
        params[b, P_ALPHA] = math.sqrt(2.0 / 3.0) * 2.0 * s / (3.0 - s)
        params[b, P_K] = m.K
    return kinds, params


def initial_Jp(materials: Sequence[Material], body_id: np.ndarray) -> np.ndarray:
    """Initial ``Jp`` of each point, shape (n,), float64.

    ``Jp`` is the plastic volume ratio for ``snow`` (1 at rest; Stomakhin et al. 2013) and the
    accumulated plastic strain for ``plasticine`` (0 at rest); no other model reads it (1).
    """
    start = np.array([0.0 if m.name == "plasticine" else 1.0 for m in materials])
    return start[np.asarray(body_id)]


# --------------------------------------------------------------------------- points
def fixed_mask(x: np.ndarray, boundaries: Iterable[Boundary]) -> np.ndarray:
    """Points held still: those inside the box ``[lo, hi]`` (closed) of any ``fixed_region``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Initial positions, metres.
    boundaries : iterable of Boundary

    Returns
    -------
    ndarray, shape (n,), bool
    """
    x = np.asarray(x, dtype=np.float64)
    mask = np.zeros(len(x), dtype=bool)
    for b in boundaries:
        if b.kind == "fixed_region":
            mask |= np.all((x >= np.asarray(b.lo, float)) & (x <= np.asarray(b.hi, float)), axis=1)
    return mask


def cell_order(x: np.ndarray, domain_lo: np.ndarray, dx: float, n_grid: int) -> np.ndarray:
    """Stable order of the points by flat grid-cell index ``(i n_grid + j) n_grid + k``.

    Scatter and gather then touch neighbouring memory (cache locality); being stable, the order
    is the same on every run. Cells are ``floor((x - domain_lo) * (1 / dx))`` clipped to the grid;
    a non-finite position counts as cell 0.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Positions, metres.
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    n_grid : int

    Returns
    -------
    ndarray, shape (n,), int64
        ``order[i]`` is the index in ``x`` of the i-th point in cell order.
    """
    X = (np.asarray(x, dtype=np.float64) - domain_lo) * (1.0 / dx)
    with np.errstate(invalid="ignore"):
        c = np.clip(np.nan_to_num(np.floor(X), nan=0.0), 0, n_grid - 1).astype(np.int64)
    key = (c[:, 0] * n_grid + c[:, 1]) * n_grid + c[:, 2]
    return np.argsort(key, kind="stable")


def material_first_order(setup, dx: float) -> tuple[np.ndarray, int]:
    """Point order of a grid engine: material points by cell, then passive points by cell.

    Parameters
    ----------
    setup : SimSetup
        ``setup.passive`` marks the passive rows (G2P only).
    dx : float
        Grid spacing, metres.

    Returns
    -------
    order : ndarray, shape (n,), int64
        ``order[i]`` is the setup row of the engine's i-th point (:func:`cell_order` within each group).
    n_material : int
        Engine points ``[:n_material]`` are material points.
    """
    if setup.passive is None:
        return cell_order(setup.x, setup.domain_lo, dx, setup.n_grid), len(setup.x)
    mat = np.flatnonzero(~setup.passive)
    pas = np.flatnonzero(setup.passive)
    order = np.concatenate([mat[cell_order(setup.x[mat], setup.domain_lo, dx, setup.n_grid)],
                            pas[cell_order(setup.x[pas], setup.domain_lo, dx, setup.n_grid)]])
    return order, len(mat)


def engine_mass_stats(x: np.ndarray, p_mass: np.ndarray) -> dict[str, Any]:
    """``mass`` (kg), ``centre_of_mass`` (m) and ``inertia`` (kg m^2, about the centre of mass) of a grid
    engine's points, for its ``stats()``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Current positions, metres, read back from the engine.
    p_mass : ndarray, shape (n,)
        The point masses the engine's P2G scatters, kg, read back from the engine in the same
        order (passive points hold 0).
    """
    from gasp_core.seam.passive import mass_properties
    return mass_properties(x, p_mass)


def stranded_passive(x: np.ndarray, grid_m: np.ndarray, domain_lo: np.ndarray, dx: float) -> int:
    """How many passive points see no node with mass in their quadratic stencil (27 nodes).

    Such a point gathers no velocity (it stays where it is) because the material has moved away
    from it: a surface left hanging where sand or liquid flowed off. Engines report it in
    ``stats()`` as ``passive_stranded``, from the last grid update.

    Parameters
    ----------
    x : ndarray, shape (m, 3)
        Passive points, metres.
    grid_m : ndarray, shape (n_grid, n_grid, n_grid)
        Node masses of the last grid update, kg (index ``[i, j, k]`` = node at ``lo + (i, j, k) dx``).
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    """
    if len(x) == 0:
        return 0
    ng = grid_m.shape[0]
    base = np.floor((np.asarray(x, np.float64) - domain_lo) / dx - 0.5).astype(np.int64)
    has = grid_m > 0
    seen = np.zeros(len(x), bool)
    for o in itertools.product(range(3), repeat=3):
        idx = np.clip(base + np.array(o), 0, ng - 1)
        seen |= has[idx[:, 0], idx[:, 1], idx[:, 2]]
    return int((~seen).sum())



#: Conformance scenes the grid engines built on this toolkit fail (they run the same algorithm,
#: docs/mpm.md), each with the measured figures; engines copy them into
#: ``EngineInfo.known_failures``.
_CLAMP_OFF_GRID = ("clamp face 0.6 dx past a grid node: time-averaged tip deflection 30.83 mm vs Euler-Bernoulli "
                   "19.99 mm (+54%); with the face on a node 21.68 mm (+8.4%). Measured also: n_grid 28/48/64 (face "
                   "0.6/0.6/0.8 dx off a node) the bar swings down as if hinged and leaves the grid by frame ~22; "
                   "n_grid 40 (on a node) 21.45 mm. fixed_region acts on whole nodes (docs/mpm.md), so the clamp is "
                   "soft when its face falls between nodes")
KNOWN_FAILURES = {"cantilever_offgrid": _CLAMP_OFF_GRID,
                  "incline_stick_cube": (
                      "the 4 dx cube on the 25 deg slope with mu = 0.8 topples instead of standing (a rigid cube tips "
                      "only beyond 45 deg): it turns 35.5 deg about its downhill bottom edge in 0.4 s, the uphill "
                      "edge lifting 1.8 dx, centroid 1.92 dx down the slope. Friction holds (the 8 x 4 x 2 dx slab of "
                      "incline_stick moves 0.04 dx; at mu = 1000 the cube topples the same way), and the plain "
                      "'ground' boundary under gravity tilted 25 deg gives the same figures, so it is the grid-node "
                      "contact (a node in the collider stops only while approaching, and carries a few % of the "
                      "block's mass), not the collider's distance field. Stiffer (E = 1e6 Pa) it stands (0.17 dx); "
                      "n_grid 48: 5.6 dx, 64: 0.85 dx (docs/colliders.md)")}
