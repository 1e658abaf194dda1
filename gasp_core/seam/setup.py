"""What the core hands an engine: materials, boundaries and the point set (:class:`SimSetup`).

World frame: metres, **z up**, gravity usually ``(0, 0, -9.81)`` m/s^2. The core converts every
object into this frame before the engine sees it and converts the result back.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.seam.schema import (BODY_MODELS, DEFAULT_MATERIAL, MATERIAL_KINDS, MATERIAL_PARAMS, MAX_FRICTION,
                                    RIGID_KINDS, STIFF_BRITTLE_E, in_range)
from gasp_core.seam.cells import crack_band, grid_spacing
from gasp_core.seam.setup_checks import broadcast, check_cells, check_passive, check_rows, vector

#: Material models an engine may offer (capability names; :data:`gasp_core.seam.schema.MATERIAL_KINDS`).
MATERIALS = frozenset(MATERIAL_KINDS)

#: Boundary kinds an engine may offer (capability names).
BOUNDARIES = frozenset({"ground", "walls", "fixed_region"})

#: The seconds a frame may last (``SimSetup.frame_dt``, the scene's ``frame_dt``): from a nanosecond to an hour.
#: Outside it the engines' step arithmetic overflows (``(1 / dt)^2`` at 1e-300 s, ``frame_dt^2`` at 1e300 s) long
#: before any physics is reached; within it ``max_substeps`` bounds the work.
FRAME_DT_RANGE = (1.0e-9, 3600.0)
#: The largest ``hardening * theta_c`` of a ``snow`` material: its stiffening ``exp(hardening theta_c)`` (Stomakhin et
#: al. 2013; 1.28 at the defaults) is then at most 2.4e17, inside float32's products (``gasp_core.seam.limits``).
MAX_STIFFENING = 40.0


@dataclass(frozen=True)
class Material:
    """Constitutive parameters of one body, SI units.

    Every parameter's default, range, unit and meaning is declared once, in
    :data:`gasp_core.seam.schema.MATERIAL_PARAMS` (checked by :meth:`check`); which of them each material
    uses is :data:`gasp_core.seam.schema.MATERIAL_KINDS` (the scene reader refuses the others).

    Attributes
    ----------
    name : str
        One of :data:`MATERIALS`.
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio, in (-1, 0.5).
    rho : float
        Density, kg/m^3.
    yield_stress : float
        von Mises yield stress, Pa (metal, plasticine): the uniaxial stress at which a bar yields
        (``gasp_core.mpm.materials.VON_MISES_RADIUS``).
    friction_angle : float
        Drucker-Prager friction angle, degrees (sand).
    grain_diameter, friction_angle_2 : float
        Sand's mu(I) rheology (Jop et al. 2006): grain diameter ``d``, m (0: rate-independent), and the angle of
        ``mu_2``, degrees (``gasp_core.mpm.materials.mu_of_I``).
    softening : float
        Plasticine softening: yield stress drop per unit plastic strain, dimensionless factor.
    hardening : float
        Snow hardening coefficient xi (Stomakhin et al. 2013).
    theta_c, theta_s : float
        Snow critical compression and stretch (Stomakhin et al. 2013).
    viscosity : float
        Kelvin-Voigt shear viscosity ``eta``, Pa s (default 0: no physical damping). The engine adds the
        viscous Cauchy stress ``sigma_v = 2 eta D``, ``D = sym(grad v)``, to the elastic one (a dashpot in
        parallel; bulk viscosity ``2 eta / 3``, ``docs/dissipation.md``). From a loss factor ``tan(delta)``
        measured at the angular frequency ``omega``: ``eta = tan(delta) mu / omega``. Needs an engine with
        the feature ``viscosity``.
    tensile_strength : float
        Rankine tensile strength ``f_t``, Pa (brittle): damage starts where the largest principal stress of the
        undamaged material passes it (``docs/fracture.md``).
    fracture_energy : float
        Fracture energy ``G_f``, J/m^2 (brittle): the work dissipated per unit crack area, whatever ``n_grid``
        (crack band of width ``dx``, Bazant & Oh 1983); a grid engine refuses ``G_f <= f_t^2 dx / (2 E)``.
    model : str
        How the engine simulates the body (issue 40; :data:`gasp_core.seam.schema.BODY_MODELS`): ``"elastic"``
        (the full model), ``"rigid"`` (the rigid limit: the body moves as one rigid body, its stress is zero, its
        stiffness sets no step; engines with the feature ``rigid_limit``) or ``"auto"`` (the default: chosen from
        the body's estimated strain, ``gasp_core.prepare.route``; a setup built in code with ``"auto"`` runs
        elastic).
    restitution, friction : float or None
        The rigid route's bounce on a hard floor, in [0, 1] (issue 53, ``gasp_core.mpm.restitution``; None: the
        substance of the material's ``E`` and ``rho``, else the default; elastic bodies bounce by their own
        vibration); Coulomb's coefficient against another body, in [0, 10] (issue 67, ``fields.field_friction``).
    """

    name: str = DEFAULT_MATERIAL
    E: float = MATERIAL_PARAMS["E"].default
    nu: float = MATERIAL_PARAMS["nu"].default
    rho: float = MATERIAL_PARAMS["rho"].default
    yield_stress: float = MATERIAL_PARAMS["yield_stress"].default
    friction_angle: float = MATERIAL_PARAMS["friction_angle"].default
    grain_diameter: float = MATERIAL_PARAMS["grain_diameter"].default
    friction_angle_2: float = MATERIAL_PARAMS["friction_angle_2"].default
    softening: float = MATERIAL_PARAMS["softening"].default
    hardening: float = MATERIAL_PARAMS["hardening"].default
    theta_c: float = MATERIAL_PARAMS["theta_c"].default
    theta_s: float = MATERIAL_PARAMS["theta_s"].default
    viscosity: float = MATERIAL_PARAMS["viscosity"].default
    tensile_strength: float = MATERIAL_PARAMS["tensile_strength"].default
    fracture_energy: float = MATERIAL_PARAMS["fracture_energy"].default
    model: str = "auto"
    restitution: float | None = None
    friction: float | None = None

    @staticmethod
    def expected(key: str, value) -> str | None:
        """None when ``value`` is a valid ``key`` (:data:`~gasp_core.seam.schema.MATERIAL_PARAMS`), else what
        is expected, in words."""
        return MATERIAL_PARAMS[key].expected(value)

    def check(self, where: str = "material") -> None:
        """Refuse a parameter outside its range (:data:`~gasp_core.seam.schema.MATERIAL_PARAMS`).

        Raises
        ------
        SceneError
            ``"{where}.nu = -1.5; expected a finite number in (-1, 0.5)"`` (the scene reader's words).
        """
        for key, param in MATERIAL_PARAMS.items():
            value = getattr(self, key)
            expected = param.expected(value)
            if expected is not None:
                raise SceneError(f"{where}.{key} = {value!r}; expected {expected}")
        if self.model not in BODY_MODELS:
            raise SceneError(f"{where}.model = {self.model!r}; expected one of {', '.join(map(repr, BODY_MODELS))}")
        for key, val, top in (("restitution", self.restitution, 1.0), ("friction", self.friction, MAX_FRICTION)):
            if val is not None and not in_range(val, 0.0, top):
                raise SceneError(f"{where}.{key} = {val!r}; expected a finite number in [0, {top:g}]")
        if self.name == "snow" and self.hardening * self.theta_c > MAX_STIFFENING:   # exp() past any precision
            raise SceneError(f"{where}.hardening = {self.hardening:g} with theta_c = {self.theta_c:g}: the snow's "
                             f"largest stiffening exp(hardening theta_c) = exp({self.hardening * self.theta_c:.3g}) "
                             f"overflows; expected hardening x theta_c <= {MAX_STIFFENING:g}")
        if self.model == "rigid" and self.name not in RIGID_KINDS:
            raise SceneError(f"{where}.model = 'rigid' needs an elastic material ({', '.join(RIGID_KINDS)}); "
                             f"{self.name!r} flows or yields")

    def snap_back_limit(self, h: float) -> float:
        """The least ``fracture_energy`` a crack band of width ``h`` (m, :func:`crack_band`) takes, J/m^2: ``f_t^2 h /
        (2 E)`` (Bazant & Oh 1983): below it the band's softening strain would be shorter than its elastic one."""
        return float(self.tensile_strength) * self.tensile_strength * h / (2.0 * self.E)   # inf past float64

    def check_band(self, h: float, where: str = "material") -> None:
        """Refuse a ``brittle`` material whose ``fracture_energy`` is at or below :meth:`snap_back_limit` at the crack
        band width ``h`` (m, :func:`crack_band`: ``dx``); other materials, and a brittle body on the
        rigid route (its ``model`` ``"rigid"``, or ``"auto"`` from ``STIFF_BRITTLE_E``: it breaks into fragments), pass.

        Raises
        ------
        SceneError
            Naming the limit, the band width ``h`` and what to change.
        """
        rigid = self.model == "rigid" or (self.model == "auto" and self.E >= STIFF_BRITTLE_E)   # fragments, no band
        if self.name == "brittle" and not self.fracture_energy > (limit := self.snap_back_limit(h)) and not rigid:
            raise SceneError(f"{where}.fracture_energy = {self.fracture_energy:g} J/m^2 is at or below the snap-back "
                             f"limit tensile_strength^2 h / (2 E) = {limit:.4g} J/m^2 at the crack band width h = "
                             f"dx = {h:.4g} m; raise fracture_energy above it, or lower "
                             f"tensile_strength, or raise n_grid")

    @property
    def K(self) -> float:
        """Bulk modulus ``E / (3 (1 - 2 nu))``, Pa."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def mu(self) -> float:
        """Lame's second parameter (shear modulus), Pa."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lam(self) -> float:
        """Lame's first parameter, Pa."""
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))

    @property
    def p_wave_speed(self) -> float:
        """Dilatational (P-wave) speed ``sqrt((lam + 2 mu) / rho)``, m/s.

        For ``liquid`` the shear modulus is not used: ``sqrt(K / rho)`` with the bulk modulus :attr:`K`; ``snow``
        takes its hardening's largest stiffening ``exp(hardening theta_c)`` (``Jp < 1``; Stomakhin et al. 2013): the
        setup's step; the grid engines then follow its state (``gasp_core.mpm.state_step``: ``Jp`` has no bound).
        """
        if self.name == "liquid":
            return math.sqrt(self.K / self.rho)
        if self.name == "snow":
            return math.sqrt(math.exp(self.hardening * self.theta_c) * (self.lam + 2.0 * self.mu) / self.rho)
        return math.sqrt((self.lam + 2.0 * self.mu) / self.rho)


@dataclass(frozen=True)
class Boundary:
    """One boundary condition, world frame.

    Attributes
    ----------
    kind : str
        ``"ground"``: a horizontal plane ``z = height``; nothing passes below it; tangential
        velocity is reduced by Coulomb friction ``friction`` (0 = slip, large = sticky).
        ``"walls"``: the faces of the domain box are walls with the same friction rule.
        ``"fixed_region"``: points that start inside the box ``[lo, hi]`` are held still.
    height : float
        Ground height, metres (``"ground"``); a scene read from a file may hold ``"auto"`` until
        :func:`gasp_core.prepare.ground.resolve_ground` sets it from the scan (an engine never sees it).
    friction : float
        Coulomb friction coefficient (``"ground"``, ``"walls"``).
    restitution : float
        Coefficient of restitution of the surface, in [0, 1] (``"ground"``, ``"walls"``; default 1, a hard floor):
        a rigid body's bounce on it is the product of this and the body's (``gasp_core.mpm.restitution``).
    lo, hi : tuple of 3 floats
        Corners of the fixed box, metres (``"fixed_region"``).
    """

    kind: str
    height: float = 0.0
    friction: float = 0.5
    restitution: float = 1.0
    lo: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hi: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class SimSetup:
    """Everything an engine needs, world frame, SI units.

    Attributes
    ----------
    x : ndarray, shape (n, 3), float64
        Initial point positions, metres. Rows ``[:n_render]`` are the triangle vertices of the
        Gaussians (or the core Gaussians' vertices); rows after are interior fill points that
        are simulated but never rendered.
    v : ndarray, shape (n, 3), float64
        Initial velocities, m/s.
    p_vol : ndarray, shape (n,), float64
        Rest volume each point stands for, m^3 (mass = rho * p_vol). Positive, except on passive
        rows (``passive``), where it is 0.
    body_id : ndarray, shape (n,), int32
        Index into ``materials`` (one body per scene object).
    materials : list of Material
        One per body.
    gravity : ndarray, shape (3,), float64
        m/s^2.
    domain_lo, domain_hi : ndarray, shape (3,), float64
        The simulation box, metres. Points leaving it are a divergence.
    n_grid : int
        Grid cells along the longest domain side (grid engines); sets ``dx``.
    boundaries : list of Boundary
    frame_dt : float
        Seconds between output frames, within :data:`FRAME_DT_RANGE` (a nanosecond to an hour).
    n_render : int
        Number of leading points that carry Gaussians.
    options : dict
        Engine options from the scene's ``[engine]`` table (``device``, ``precision``,
        ``dt``, ``n_substeps``, ``cfl``, ...). The core is their only checker: before the factory runs,
        :func:`gasp_core.seam.build.build_engine` checks them against the engine's declared
        :class:`~gasp_core.seam.engine.Option` s (types, ranges, choices, ``excludes``) and completes
        them with the defaults, so an engine reads every declared option here and checks none again.
    C : ndarray, shape (n, 3, 3), float64, or None
        Initial velocity gradient per point, 1/s (APIC's affine matrix ``C``; for a body spinning
        at angular velocity w it is the cross-product matrix of w). None means zero. Grid engines
        start their ``C`` from it, so a rotating body does not lose the sub-cell part of its
        angular momentum in the first transfer; other engines may ignore it.
    passive : ndarray, shape (n,), bool, or None
        Passive points (objects with ``surface = "passive"``): they are carried by the motion of
        the material but carry no mass (``p_vol == 0``), no stress and no deformation gradient.
        Only rendered rows (``[:n_render]``) may be passive; the material points (the fill)
        then represent the whole solid. Engines with the feature ``passive_points`` move them
        themselves (grid engines: G2P only, no P2G); for the others the core embeds them in the
        material points' motion (:mod:`gasp_core.seam.passive`). None means no passive point.
    faint : ndarray, shape (n,), bool, or None
        Rendered rows moved by Gaussians under ``min_opacity`` only (floaters): no rigid body rests on them.
    colliders : list of gasp_core.colliders.model.Collider
        Rigid obstacles (signed distance fields, friction, prescribed motion); features
        ``static_colliders`` / ``moving_colliders``.
    forces : list of gasp_core.colliders.model.ForceField
        Wind (a surface drag law) and attractors (acceleration fields); features ``wind`` / ``attractors``.
    impulses : list of gasp_core.colliders.model.Impulse
        Velocity changes of a region over a time window; feature ``impulse``.
    cells : ndarray, shape (n,), int32, or None
        Grady's cells of a soft brittle body laid out at its landing (:mod:`gasp_core.run.grady_cells`): a band
        point's cell (>= 0), ``-2 - cell`` for a cell's inside (it never damages), -1 for a point in no cell; feature
        ``fracture_cells``. None: no cells.

    Raises
    ------
    SceneError
        A field's shape, sign, range or a non-finite value, named (:mod:`gasp_core.seam.setup_checks`, and below).
    """

    x: np.ndarray
    v: np.ndarray
    p_vol: np.ndarray
    body_id: np.ndarray
    materials: list[Material]
    gravity: np.ndarray
    domain_lo: np.ndarray
    domain_hi: np.ndarray
    n_grid: int = 64
    boundaries: list[Boundary] = field(default_factory=list)
    frame_dt: float = 1.0 / 30.0
    n_render: int = -1
    options: dict[str, Any] = field(default_factory=dict)
    C: np.ndarray | None = None
    passive: np.ndarray | None = None
    faint: np.ndarray | None = None
    colliders: list = field(default_factory=list)
    forces: list = field(default_factory=list)
    impulses: list = field(default_factory=list)
    cells: np.ndarray | None = None

    def __post_init__(self):
        self.x = np.ascontiguousarray(self.x, dtype=np.float64)
        n = len(self.x)
        if self.x.ndim != 2 or self.x.shape[1] != 3:
            raise SceneError(f"SimSetup.x: expected shape (n, 3), got {self.x.shape}")
        self.v = broadcast("v", self.v, (n, 3), np.float64)
        self.p_vol = broadcast("p_vol", self.p_vol, (n,), np.float64)
        self.body_id = broadcast("body_id", self.body_id, (n,), np.int32)
        self.gravity, self.domain_lo, self.domain_hi = (vector(k, getattr(self, k))
                                                        for k in ("gravity", "domain_lo", "domain_hi"))
        if self.n_render < 0 or self.n_render > n:   # past the points (a subset made by dataclasses.replace): all
            self.n_render = n
        check_rows(self.body_id, n, self.n_render, self.boundaries)
        if self.C is not None:
            self.C = broadcast("C", self.C, (n, 3, 3), np.float64)
        if not np.all(np.isfinite(self.x)):
            bad = int(np.flatnonzero(~np.isfinite(self.x).all(axis=1))[0])
            raise SceneError(f"SimSetup.x: non-finite position at point {bad}")
        if len(self.materials) == 0 or (n and self.body_id.max() >= len(self.materials)):
            raise SceneError("SimSetup.body_id: refers to a material that is not in SimSetup.materials")
        if n == 0:
            raise SceneError("SimSetup.x: no points")
        if not np.all(np.isfinite(self.v)):
            raise SceneError("SimSetup.v: velocities must be finite")
        if self.passive is not None:
            self.passive = broadcast("passive", self.passive, (n,), bool)
            if not self.passive.any():
                self.passive = None
        if self.faint is not None:
            self.faint = broadcast("faint", self.faint, (n,), bool)
            if self.faint[self.n_render:].any():
                raise SceneError("SimSetup.faint: only rendered rows [:n_render] may be faint")
            self.faint = self.faint if self.faint.any() else None
        massless = np.zeros(n, bool) if self.passive is None else self.passive
        if np.any(self.p_vol[~massless] <= 0) or not np.all(np.isfinite(self.p_vol)):
            raise SceneError("SimSetup.p_vol: volumes must be positive and finite (0 only on passive rows)")
        check_passive(self.passive, self.p_vol, self.body_id, self.n_render, len(self.materials))
        if self.cells is not None:
            self.cells = check_cells(self.cells, n, self.passive)
        if not np.all(self.domain_hi > self.domain_lo):
            raise SceneError(f"SimSetup.domain_hi must exceed domain_lo on every axis, got "
                             f"{self.domain_lo.tolist()} / {self.domain_hi.tolist()}")
        if not (isinstance(self.n_grid, (int, np.integer)) and self.n_grid >= 4):
            raise SceneError(f"SimSetup.n_grid = {self.n_grid!r}; expected an integer >= 4")
        if not (FRAME_DT_RANGE[0] <= self.frame_dt <= FRAME_DT_RANGE[1]):
            raise SceneError(f"SimSetup.frame_dt = {self.frame_dt}; expected a number of seconds in "
                             f"[{FRAME_DT_RANGE[0]:g}, {FRAME_DT_RANGE[1]:g}]")
        band = self.crack_band
        for i, m in enumerate(self.materials):
            m.check(f"SimSetup.materials[{i}] ({m.name!r})")
            m.check_band(float(band[i]), f"SimSetup.materials[{i}] ({m.name!r})")

    @property
    def dx(self) -> float:
        """Grid spacing, metres: the longest domain side divided by ``n_grid`` (:func:`grid_spacing`)."""
        return grid_spacing(self.domain_lo, self.domain_hi, self.n_grid)

    @property
    def crack_band(self) -> np.ndarray:
        """Crack band width of each body, metres, shape (n_bodies,) (:func:`crack_band`): a ``brittle`` body's
        softening is scaled to it (``gasp_core.mpm.materials.material_table``)."""
        return crack_band(self.dx, self.p_vol, self.body_id, len(self.materials))

    @property
    def n_passive(self) -> int:
        """Number of passive rows (``passive``), 0 when there are none."""
        return 0 if self.passive is None else int(self.passive.sum())

    @property
    def material_mask(self) -> np.ndarray:
        """Rows that carry mass (not passive), shape (n,), bool."""
        return np.ones(len(self.x), bool) if self.passive is None else ~self.passive

    @property
    def p_mass(self) -> np.ndarray:
        """Point masses, kg, shape (n,)."""
        rho = np.array([m.rho for m in self.materials])
        return rho[self.body_id] * self.p_vol

    def replace(self, **changes) -> "SimSetup":
        """A copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)
