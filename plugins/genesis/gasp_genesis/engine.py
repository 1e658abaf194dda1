"""The ``genesis`` engine: a :class:`gasp_core.seam.engine.PointEngine` over Genesis's MPM solver.

Genesis (``genesis-world``, tested with 1.4.5 on torch 2.13 CPU) runs MLS-MPM with quadratic
B-splines and APIC transfers in ``genesis/engine/solvers/mpm_solver.py``; this module builds one
Genesis ``Scene`` per engine from a :class:`gasp_core.seam.engine.SimSetup` and reads the particles back.

How the setup maps onto Genesis (API of ``genesis/options/solvers.py``, ``genesis/options/morphs.py``,
``genesis/engine/entities/mpm_entity.py``):

- ``gs.init(backend=gs.cpu | gs.cuda, precision="32" | "64", logging_level="warning")`` is called
  **once per process**, by the first engine built (Genesis refuses a second ``gs.init``). Every
  later engine in the process must ask for the same device and precision, else ``EngineError``.
  Several engines (scenes) may live in one process.
- ``MPMOptions(lower_bound=domain_lo, upper_bound=domain_hi, grid_density=1/dx)`` with GASP's
  ``dx = max(domain_hi - domain_lo) / n_grid``. Genesis keeps particles inside the box shrunk by
  ``3 dx`` (its ``CubeBoundary``: slip walls, no friction) and aligns grid nodes to multiples of
  ``dx`` in world coordinates (GASP's spec aligns them to ``domain_lo``).
- ``SimOptions(dt=frame_dt, substeps=n_substeps, gravity=gravity)``: one ``scene.step()`` per frame.
- One MPM entity per body: ``gs.morphs.Nowhere(n_particles=...)``, then, after ``scene.build()``,
  ``set_particles_pos``, ``set_particles_vel`` and ``set_particles_active`` with our points.
- ``MPMOptions.particle_size = cbrt(mean(p_vol))``: Genesis has **one particle volume per solver**
  (mass = rho * particle_size^3), so per-point volumes are replaced by their mean (total volume
  and mass kept). ``stats()["p_vol_spread"]`` gives ``max/min - 1`` of the input volumes. So that
  every point keeps its mass, each body is split into up to :data:`MASS_CLASSES` entities of
  points of similar mass (:func:`mass_classes`; one MPM grid, so the split does not change the
  motion), each with its density scaled to ``rho_g' = mean_g(rho_b p_vol_i) / p_vol`` (elastic
  moduli unchanged). ``stats()`` reads the mass back from Genesis (``entity.get_mass()``) and
  reports the centre-of-mass and mass residuals against the setup's (conformance scene
  ``mass_agreement``).
- ``ground``: a fixed rigid ``gs.morphs.Plane`` at ``z = height`` with
  ``gs.materials.Rigid(coup_friction=friction, coup_softness=0, coup_restitution=0)``; Genesis's
  MPM-rigid coupling (``legacy_coupler._func_collide_in_rigid_geom``) applies the same Coulomb rule
  as ``docs/mpm.md`` to grid nodes on or below the plane.
- ``walls``: Genesis's own domain box (slip). With ``friction > 0`` six more planes on the box
  faces add the Coulomb friction. Without ``walls``, a point that reaches the box is reported as
  ``EngineDivergence`` ("points left the domain"), since Genesis would hold it there.
"""
from __future__ import annotations

import dataclasses
import importlib.metadata as md
import time
from typing import Any

import numpy as np

from gasp_core.mpm.substeps import substeps_from_options
from gasp_core.seam import (CAUSE_LEFT_DOMAIN, CAUSE_UNSTABLE, EngineDivergence, EngineError, Material,
                           SceneError, SimSetup)

from . import ENGINE, INSTALL_HINT, PADDING_CELLS



#: Most Genesis entities per body: Genesis gives every particle of an entity the same mass.
MASS_CLASSES = 8


def _with_rho(m: Material, rho: float) -> Material:
    return dataclasses.replace(m, rho=rho)


def mass_classes(p_mass: np.ndarray, k: int = MASS_CLASSES) -> list[np.ndarray]:
    """Rows of one body grouped by mass, one Genesis entity each.

    Parameters
    ----------
    p_mass : ndarray, shape (n,)
        Point masses of the body, kg.
    k : int
        Most groups.

    Returns
    -------
    list of ndarray of int64
        Rows of ``p_mass``, every row in one group: one group per distinct mass when there are at
        most ``k`` of them (exact), else ``k`` groups of equal count in order of mass (each point
        then gets its group's mean mass; total mass and the groups' centres of mass are kept).
    """
    p_mass = np.asarray(p_mass, dtype=np.float64)
    values, inverse = np.unique(p_mass, return_inverse=True)
    if len(values) <= k:
        return [np.flatnonzero(inverse == j) for j in range(len(values))]
    return [g for g in np.array_split(np.argsort(p_mass, kind="stable"), k) if len(g)]


def time_step(setup: SimSetup, opt: dict[str, Any]) -> tuple[int, float]:
    """Substeps per frame and substep length (``gasp_core.mpm.substeps.mpm_substeps``, docs/mpm.md)."""
    return substeps_from_options(setup, opt, ENGINE)


# ---------------------------------------------------------------------- Genesis
def init_genesis(device: str = "cpu", precision: str = "f32"):
    """Import Genesis and call ``gs.init`` once per process; return the ``genesis`` module.

    Parameters
    ----------
    device : {"cpu", "cuda"}
    precision : {"f32", "f64"}
        Genesis's ``precision="32"`` or ``"64"`` (``gs.init``).

    Raises
    ------
    EngineError
        Genesis cannot be imported; the device is not available; or Genesis is already
        initialised in this process with another backend or precision (``gs.init`` may run once).
    """
    try:
        import genesis as gs
    except Exception as e:  # ImportError, or a broken binary dependency
        raise EngineError(f"engine '{ENGINE}': genesis cannot be imported ({type(e).__name__}: {e}); "
                          f"{INSTALL_HINT}") from e
    want_prec = "32" if precision == "f32" else "64"
    if gs._initialized:
        cur_prec = "32" if np.dtype(gs.np_float) == np.float32 else "64"
        cur_dev = "cpu" if gs.backend == gs.cpu else "cuda"
        if (cur_dev, cur_prec) != (device, want_prec):
            raise EngineError(
                f"engine '{ENGINE}': Genesis is already initialised in this process with device "
                f"'{cur_dev}', precision 'f{cur_prec}'; this scene asks for device '{device}', "
                f"precision '{precision}' (gs.init runs once per process: use one device and "
                f"precision per process)")
        return gs
    backend = gs.cpu if device == "cpu" else gs.cuda
    try:
        gs.init(backend=backend, precision=want_prec, logging_level="warning")
    except Exception as e:  # GenesisException: backend not available
        raise EngineError(f"engine '{ENGINE}': gs.init(backend={device}) failed: {e}") from e
    return gs


def genesis_material(gs, m: Material):
    """The Genesis MPM material for a GASP :class:`~gasp_core.seam.engine.Material`.

    Parameters
    ----------
    gs : module
        The initialised ``genesis`` module.
    m : Material
        ``name`` in :data:`gasp_genesis.CAPABILITIES` ``.materials``; E (Pa), nu, rho (kg/m^3).

    Returns
    -------
    genesis.engine.materials.MPM.Base

    Notes
    -----
    ``liquid``: Genesis's stress is ``lam J (J - 1) I`` with ``mu = 0``; ``lam`` is given the bulk
    modulus ``K = E / (3 (1 - 2 nu))`` (``Material.K``) so that it is ``K J (J - 1) I`` as in ``docs/mpm.md``.
    """
    M = gs.materials.MPM
    kw = dict(E=float(m.E), nu=float(m.nu), rho=float(m.rho))
    if m.name == "jelly":
        return M.Elastic(model="corotation", **kw)
    if m.name == "neo_hookean":
        return M.Elastic(model="neohooken", **kw)
    if m.name == "metal":
        return M.ElastoPlastic(use_von_mises=True, von_mises_yield_stress=float(m.yield_stress), **kw)
    if m.name == "sand":
        return M.Sand(friction_angle=float(m.friction_angle), **kw)
    if m.name == "snow":
        return M.Snow(yield_lower=float(m.theta_c), yield_higher=float(m.theta_s), **kw)
    if m.name == "liquid":
        return M.Liquid(viscous=False, lam=float(m.K), **kw)
    raise SceneError(f"engine '{ENGINE}': material {m.name!r} is not supported")  # validated before


def _plane(gs, pos, normal, friction: float):
    return dict(
        morph=gs.morphs.Plane(pos=tuple(float(c) for c in pos), normal=tuple(float(c) for c in normal)),
        material=gs.materials.Rigid(coup_friction=float(friction), coup_softness=0.0,
                                    coup_restitution=0.0),
    )


# ---------------------------------------------------------------------- engine
class GenesisMPMEngine:
    """Genesis MPM engine (see the module docstring for the mapping).

    Parameters
    ----------
    setup : SimSetup
        World frame (z up), SI units. ``setup.options`` (checked and completed by the core) hold ``device`` ("cpu" | "cuda"),
        ``precision`` ("f32" | "f64"), ``dt`` (s) or ``n_substeps`` (per frame) and ``cfl`` (0.4).

    Raises
    ------
    SceneError
        A point outside Genesis's padded box ``[domain_lo + 3 dx, domain_hi - 3 dx]``.
    EngineError
        Genesis missing, device unavailable, or Genesis initialised otherwise in this process.

    Notes
    -----
    Building compiles Genesis's kernels (quadrants, a Taichi fork): about a minute on 2 CPU cores
    the first time, ~10 s when the kernel cache (``~/.cache/quadrants``) is warm.
    """

    def __init__(self, setup: SimSetup):
        opt = setup.options  # checked and completed by the core (build_engine)
        self.setup = setup
        self.options = opt
        self.n_substeps, self.dt = time_step(setup, opt)
        dx = setup.dx
        pad = PADDING_CELLS * dx
        self.box_lo = setup.domain_lo + pad
        self.box_hi = setup.domain_hi - pad
        inside = np.all((setup.x >= self.box_lo) & (setup.x <= self.box_hi), axis=1)
        if not inside.all():
            bad = int(np.flatnonzero(~inside)[0])
            raise SceneError(
                f"engine '{ENGINE}': point {bad} at {setup.x[bad].tolist()} lies outside Genesis's "
                f"MPM box [domain_lo + 3 dx, domain_hi - 3 dx] = [{self.box_lo.tolist()}, "
                f"{self.box_hi.tolist()}] ({int((~inside).sum())} points); enlarge the domain")

        gs = init_genesis(opt["device"], opt["precision"])
        self._gs = gs
        self._np_float = np.dtype(gs.np_float)
        self.p_vol_used = float(np.mean(setup.p_vol))
        self.p_vol_spread = float(np.max(setup.p_vol) / np.min(setup.p_vol) - 1.0)

        t0 = time.perf_counter()
        try:
            scene = self._build_scene(gs, setup, dx)
        except gs.GenesisException as e:  # Genesis refused a parameter (gs.raise_exception)
            raise SceneError(f"engine '{ENGINE}': Genesis refused the scene: {e}") from e
        self.build_s = time.perf_counter() - t0
        self.scene = scene
        self.frame = 0
        self._x = setup.x.astype(self._np_float)
        self._v = setup.v.astype(self._np_float)
        self._closed = False

    def _build_scene(self, gs, setup: SimSetup, dx: float):
        """The Genesis scene: planes for ground and walls, one MPM entity per body, particles set."""
        scene = gs.Scene(
            sim_options=gs.options.SimOptions(dt=float(setup.frame_dt), substeps=int(self.n_substeps),
                                              gravity=tuple(float(g) for g in setup.gravity)),
            mpm_options=gs.options.MPMOptions(
                lower_bound=tuple(float(c) for c in setup.domain_lo),
                upper_bound=tuple(float(c) for c in setup.domain_hi),
                grid_density=1.0 / dx,
                particle_size=self.p_vol_used ** (1.0 / 3.0)),
            show_viewer=False,
        )
        # Rigid planes: ground(s), and the box faces when walls have friction.
        self.walls = any(b.kind == "walls" for b in setup.boundaries)
        self.grounds = [b for b in setup.boundaries if b.kind == "ground"]
        self.n_planes = 0
        for b in self.grounds:
            scene.add_entity(**_plane(gs, (0.0, 0.0, b.height), (0.0, 0.0, 1.0), b.friction))
            self.n_planes += 1
        wall_friction = max([b.friction for b in setup.boundaries if b.kind == "walls"], default=0.0)
        if self.walls and wall_friction > 0:
            for d in range(3):
                e = np.eye(3)[d]
                lo_pt = np.where(e > 0, self.box_lo, 0.5 * (self.box_lo + self.box_hi))
                hi_pt = np.where(e > 0, self.box_hi, 0.5 * (self.box_lo + self.box_hi))
                scene.add_entity(**_plane(gs, lo_pt, e, wall_friction))
                scene.add_entity(**_plane(gs, hi_pt, -e, wall_friction))
                self.n_planes += 2
        self.wall_friction = wall_friction if self.walls else None

        # MPM entities per body, one per mass class (mass_classes), points in entity order;
        # self._order maps back to setup order.
        self._bodies = []
        order = []
        p_mass = setup.p_mass
        for b, m in enumerate(setup.materials):
            rows = np.flatnonzero(setup.body_id == b)
            for g in mass_classes(p_mass[rows]):
                idx = rows[g]
                rho_g = float(p_mass[idx].mean()) / self.p_vol_used   # the class's mean point mass
                ent = scene.add_entity(material=genesis_material(gs, _with_rho(m, rho_g)),
                                       morph=gs.morphs.Nowhere(n_particles=int(len(idx))))
                self._bodies.append((ent, idx))
                order.append(idx)
        self._order = np.concatenate(order)
        scene.build()
        for ent, idx in self._bodies:
            ent.set_particles_pos(np.ascontiguousarray(setup.x[idx], dtype=self._np_float))
            ent.set_particles_vel(np.ascontiguousarray(setup.v[idx], dtype=self._np_float))
            ent.set_particles_active(np.ones(len(idx), dtype=bool))
        return scene

    # ------------------------------------------------------------------ interface
    def _read(self, getter: str) -> np.ndarray:
        out = np.empty((len(self.setup.x), 3), dtype=self._np_float)
        for ent, idx in self._bodies:
            out[idx] = getattr(ent, getter)().cpu().numpy()
        return out

    def step_frame(self) -> None:
        """Advance ``frame_dt`` seconds: one ``scene.step()`` of ``n_substeps`` substeps of ``dt``.

        Raises
        ------
        EngineDivergence
            Genesis reports NaN in the MPM state, a position or velocity is non-finite, or (without
            ``walls``) a point reached Genesis's domain box (the message gives the count and the
            first point index in setup order).
        EngineError
            The engine was closed.
        """
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': this engine was closed")
        gs = self._gs
        try:
            self.scene.step(update_visualizer=False)
        except gs.GenesisException as e:
            self.frame += 1
            raise EngineDivergence(f"Genesis stopped: {e}", self.frame, CAUSE_UNSTABLE) from e
        self.frame += 1
        x_prev = self._x
        x = self._read("get_particles_pos")
        v = self._read("get_particles_vel")
        self._x, self._v = x, v
        finite = np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1)
        if not finite.all():
            bad = np.flatnonzero(~finite)
            raise EngineDivergence(f"{len(bad)} point(s) with non-finite position or velocity "
                                   f"(first index {bad[0]})", self.frame, CAUSE_UNSTABLE)
        if not self.walls:
            tol = 1e-3 * self.setup.dx
            at_lo = x <= self.box_lo + tol
            at_hi = x >= self.box_hi - tol
            if any(b.height <= self.box_lo[2] + tol for b in self.grounds):
                at_lo[:, 2] = False  # Genesis's floor stands in for a ground below its padded box
            out = (at_lo | at_hi).any(axis=1)
            if out.any():
                bad = np.flatnonzero(out)
                # a point that moved more than dx/2 per substep broke the CFL limit: a blow-up
                step = float(np.max(np.linalg.norm(x - x_prev, axis=1))) / self.n_substeps
                fast = step > 0.5 * self.setup.dx
                raise EngineDivergence(
                    f"{len(bad)} point(s) reached the domain box (first index {bad[0]} at "
                    f"{x[bad[0]].tolist()}); the scene has no walls", self.frame,
                    CAUSE_UNSTABLE if fast else CAUSE_LEFT_DOMAIN)

    def positions(self) -> np.ndarray:
        """Current positions, shape (n, 3), float32 (f32) or float64 (f64), metres, setup order."""
        return self._x.copy()

    def velocities(self) -> np.ndarray:
        """Current velocities, shape (n, 3), m/s, setup order."""
        return self._v.copy()

    def stats(self) -> dict[str, Any]:
        """``device, precision, n_points, dt, n_substeps, n_grid, dx`` and Genesis specifics.

        ``p_vol`` (m^3, the one particle volume used), ``p_vol_spread`` (``max/min - 1`` of the
        input volumes), ``build_s`` (scene build incl. kernel compilation, s), ``n_planes``,
        ``wall_friction``, ``genesis_version``, ``frame``.
        """
        try:
            version = md.version("genesis-world")
        except md.PackageNotFoundError:
            version = ""
        return {
            "device": self.options["device"],
            "precision": self.options["precision"],
            "n_points": int(len(self.setup.x)),
            "dt": float(self.dt),
            "n_substeps": int(self.n_substeps),
            "n_grid": int(self.setup.n_grid),
            "dx": float(self.setup.dx),
            "p_vol": self.p_vol_used,
            "p_vol_spread": self.p_vol_spread,
            "build_s": float(self.build_s),
            "n_planes": int(self.n_planes),
            "wall_friction": self.wall_friction,
            "genesis_version": version,
            "frame": self.frame,
            **self._mass_stats(),
        }

    def _mass_stats(self) -> dict[str, Any]:
        """``mass`` (kg), ``centre_of_mass`` (m) and ``inertia`` (kg m^2) as Genesis holds them (each
        entity's ``get_mass()`` spread evenly on its particles), and ``mass_residual`` (relative) and
        ``com_residual`` (m) against the setup's ``rho p_vol`` at the same positions."""
        from gasp_core.seam.passive import mass_properties
        if self._closed:
            return {}
        m = np.zeros(len(self.setup.x))
        for ent, idx in self._bodies:
            total = float(np.asarray(ent.get_mass().cpu().numpy(), dtype=np.float64).ravel()[0])
            m[idx] = total / len(idx)
        x = self._x.astype(np.float64)
        got = mass_properties(x, m)
        want = mass_properties(x, self.setup.p_mass)
        got["mass_residual"] = got["mass"] / want["mass"] - 1.0
        got["com_residual"] = float(np.linalg.norm(np.subtract(got["centre_of_mass"], want["centre_of_mass"])))
        return got

    def close(self) -> None:
        """Destroy the Genesis scene (frees its fields); later calls raise ``EngineError``."""
        if not self._closed:
            self._closed = True
            scene, self.scene = self.scene, None
            if scene is not None:
                scene.destroy()
