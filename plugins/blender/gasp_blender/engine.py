"""The ``blender`` engine: one headless Blender scene built from a :class:`~gasp_core.seam.engine.SimSetup`.

Per body (``setup.body_id``), a soft body on a coarse voxel cage (:mod:`.cage`): a Blender mesh
whose vertices are the cage corners and whose edges are the cage springs, with a ``SOFT_BODY``
modifier; the input points ride on the cage trilinearly. ``ground`` is a plane with a
``COLLISION`` modifier; ``fixed_region`` pins cage vertices through the soft-body goal (a vertex
group of weight 1, which Blender snaps exactly onto the rest position).

Units (Blender 4.x ``softbody.cc``): the soft-body solver is frame based. One frame advances its
clock by ``speed`` (``SoftBodySettings.speed``) time units; gravity enters as ``0.001 g`` per unit
mass ("unit mass of node rescaled to 1 gram"); a spring of rest length ``L0`` pulls with
``k (L0 - L) / L0`` where ``k = 1 / (1 - pull) - 1``. With ``speed = frame_dt * sqrt(1000)``, one
frame is ``frame_dt`` seconds and gravity is SI; with a mass unit ``mu`` kg (the heaviest cage vertex
weighs 1), an SI spring ``k_SI`` becomes ``k = k_SI L0 / (1000 mu)``. See ``README.md``.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from gasp_core.seam import check_state, EngineError, Option, SceneError, SimSetup

from . import SPEED_PER_FRAME_DT
from .cage import Cage, build_cage, embed, interpolate, lump
from .sheet import build_sheet, place

ENGINE = "blender"

#: Engine options (``[engine]`` table of a scene), declared as data (``gasp engines`` lists them).
OPTIONS = (
    Option("device", "cpu", "where to run: only 'cpu'", kind="str", choices=("cpu",)),
    Option("precision", "f32", "only 'f32' (Blender stores positions in float32)", kind="str", choices=("f32",)),
    Option("mode", "softbody", "'softbody' (voxel cage) or 'cloth' (a quad sheet through a thin body)",
           kind="str", choices=("softbody", "cloth")),
    Option("tension", 15.0, "cloth only: tension/compression/shear stiffness, Blender units (not from E)",
           lo=0.0, hi=10000.0),
    Option("bending", 0.5, "cloth only: bending stiffness, Blender units (not from E)", lo=0.0, hi=10000.0),
    Option("cells_across", 6, "cage cells along a body's longest side", kind="int", lo=1),
    Option("cell_size", None, "cage cell size h, m (overrides cells_across)", lo=0.0, lo_open=True),
    Option("step_min", 20, "soft-body solver: minimum steps per frame (SoftBodySettings.step_min)", kind="int", lo=1),
    Option("step_max", 300, "soft-body solver: maximum steps per frame (step_max)", kind="int", lo=1),
    Option("dt", None, "largest solver step, s: sets step_min = ceil(frame_dt / dt)", lo=0.0, lo_open=True),
    Option("error_threshold", 0.001, "Heun error limit (error_threshold); Blender's 0.1 lets light cage "
           "corners go unstable", lo=0.001, hi=10.0),
    Option("damping", 0.5, "edge spring damping, Blender units (SoftBodySettings.damping)", lo=0.0, hi=50.0),
    Option("collision_damping", 0.5, "ground collision damping (CollisionSettings.damping)", lo=0.0, hi=1.0),
    Option("thickness", 0.001, "ground outer thickness, m (CollisionSettings.thickness_outer)", lo=0.001, hi=1.0),
)

#: Young's modulus of the cubic spring cage in units of K' / h^2 (see _build).
LATTICE_E = (1.0 + math.sqrt(2.0) + 4.0 / (3.0 * math.sqrt(3.0))) * (1.25 * 0.5 / 0.75)

#: Largest spring constant Blender accepts: pull <= 0.999 -> k = 1 / (1 - pull) - 1 = 999.
K_MAX = 999.0


#: The engine that owns bpy's one scene in this process (a new engine takes it over).
_OWNER = None


def _import_bpy():
    try:
        import bpy  # noqa: F401
    except Exception as e:  # ImportError, or a broken install raising something else
        raise EngineError(f"engine '{ENGINE}': cannot import bpy ({type(e).__name__}: {e}); "
                          "pip install 'gasp-blender[engine]'") from None
    return bpy


class _Body:
    def __init__(self, idx, cage: Cage, cell, w, pinned, mu, k, k_si, mass_kg):
        self.idx, self.cage, self.cell, self.w = idx, cage, cell, w
        self.pinned, self.mu, self.k, self.k_si, self.mass_kg = pinned, mu, k, k_si, mass_kg
        self.obj = None


class BlenderSoftBodyEngine:
    """A running Blender soft-body simulation of a :class:`~gasp_core.seam.engine.SimSetup`.

    Parameters
    ----------
    setup : SimSetup
        World frame, metres, z up. ``setup.options`` holds every option of :data:`OPTIONS`,
        checked and completed by the core (``gasp_core.seam.build.build_engine``).

    Raises
    ------
    SceneError
        ``step_max`` below ``step_min`` (after ``dt``), non-zero initial velocities (Blender starts soft
        bodies at rest). (Options, a material or boundary the engine lacks, and a ``frame_dt`` outside what
        Blender's ``speed`` accepts, :data:`gasp_blender.LIMITS`, are refused by the core first.)
    EngineError
        bpy cannot be imported.

    Notes
    -----
    bpy has one scene per process: building a second ``blender`` engine takes it over, and stepping
    the first one then raises :class:`EngineError`. ``velocities()`` are backward differences of the positions over one frame (Blender's point
    cache holds the solver's velocities but bpy does not expose them).
    """

    def __init__(self, setup: SimSetup):
        self.setup = setup
        o = dict(setup.options)  # checked and completed by the core (build_engine); step_min may change below
        self.options = o
        if o["dt"] is not None:
            o["step_min"] = max(1, math.ceil(setup.frame_dt / o["dt"] - 1e-9))
            o["step_max"] = max(o["step_max"], o["step_min"])
        if o["step_max"] < o["step_min"]:
            raise SceneError(f"engine '{ENGINE}': option step_max={o['step_max']} < step_min={o['step_min']}")
        if np.any(setup.v != 0.0):
            raise SceneError(f"engine '{ENGINE}': initial velocities are not supported (Blender starts "
                             "soft bodies at rest and bpy cannot set their velocities)")
        self.speed = setup.frame_dt * SPEED_PER_FRAME_DT  # in Blender's range: gasp_blender.LIMITS, checked by the core
        self.frame = 0
        self.n_points = len(setup.x)
        self._x = setup.x.copy()
        self._v = np.zeros_like(setup.x)
        self.bpy = _import_bpy()
        global _OWNER
        _OWNER = self
        self._build()

    # ------------------------------------------------------------------ scene construction
    def _fixed_mask(self, x: np.ndarray) -> np.ndarray:
        mask = np.zeros(len(x), dtype=bool)
        for b in self.setup.boundaries:
            if b.kind == "fixed_region":
                mask |= np.all((x >= np.asarray(b.lo)) & (x <= np.asarray(b.hi)), axis=1)
        return mask

    def _build(self) -> None:
        bpy, s, o = self.bpy, self.setup, self.options
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        scene.unit_settings.system = "METRIC"
        scene.unit_settings.scale_length = 1.0
        scene.use_gravity = True
        scene.gravity = tuple(float(g) for g in s.gravity)
        # one Blender frame = frame_dt (the soft-body solver itself is frame based: see speed)
        fps = max(1, int(round(1.0 / s.frame_dt)))
        scene.render.fps = fps
        scene.render.fps_base = fps * s.frame_dt
        scene.frame_start = 1
        scene.frame_end = 1_000_000
        scene.frame_set(1)

        self.bodies: list[_Body] = []
        fixed = self._fixed_mask(s.x)
        for b, mat in enumerate(s.materials):
            idx = np.flatnonzero(s.body_id == b)
            if len(idx) == 0:
                continue
            xb = s.x[idx]
            if o["mode"] == "cloth":
                self.bodies.append(self._add_cloth(f"gasp_body_{b}", idx, xb, mat, fixed[idx]))
                continue
            ext = float(np.max(xb.max(0) - xb.min(0)))
            h = float(o["cell_size"]) if o["cell_size"] is not None else max(ext, 1e-6) / o["cells_across"]
            cage = build_cage(xb, h)
            cell, w = embed(cage, xb)
            m_kg = lump(cage, cell, np.clip(w, 0.0, None), mat.rho * s.p_vol[idx])
            m_kg = np.maximum(m_kg, 0.01 * m_kg.max())   # Blender clamps node masses below 0.01 units
            mu = float(m_kg.max())                        # mass unit: the heaviest vertex weighs 1
            # Blender gives every spring the same k: SI stiffness K' / L0 with K' = 1000 mu k.
            # A cubic cell with its 12 edges, 12 face and 4 body diagonals at stiffness K' / L0 has
            # C11 = (1 + sqrt 2 + 4 / (3 sqrt 3)) K' / h^2 and Poisson's ratio 1/4 (Cauchy), so
            # Young's modulus E_lattice = LATTICE_E * K' / h^2; pick K' so that E_lattice = E.
            k_si = mat.E * h * h / LATTICE_E      # K', N (SI spring constant times rest length)
            k = k_si / (1000.0 * mu)
            pinned = np.zeros(len(cage.vertices), dtype=bool)
            if fixed[idx].any():
                pinned[np.unique(cage.cell_vertices[cell[fixed[idx]]])] = True
            body = _Body(idx, cage, cell, w, pinned, mu, k, k_si, m_kg)
            body.obj = self._add_softbody(f"gasp_body_{b}", body)
            self.bodies.append(body)
        for bd in s.boundaries:
            if bd.kind == "ground":
                self._add_ground(bd)
        self.depsgraph = bpy.context.evaluated_depsgraph_get()
        self._x = self._read_positions()

    def _add_softbody(self, name: str, body: _Body):
        bpy, o = self.bpy, self.options
        cage = body.cage
        me = bpy.data.meshes.new(name)
        me.from_pydata(cage.vertices.tolist(), cage.edges.tolist(), [])
        me.update()
        obj = bpy.data.objects.new(name, me)
        bpy.context.scene.collection.objects.link(obj)
        vg_mass = obj.vertex_groups.new(name="mass")
        w = body.mass_kg / body.mu
        for i, wi in enumerate(w):
            vg_mass.add([i], float(wi), "REPLACE")
        mod = obj.modifiers.new("softbody", "SOFT_BODY")
        sb = mod.settings
        sb.mass = 1.0
        sb.vertex_group_mass = "mass"
        sb.friction = 0.0              # no drag of a surrounding medium (air)
        sb.speed = self.speed
        sb.use_edges = True
        sb.use_stiff_quads = False
        sb.bend = 0.0
        k = min(body.k, K_MAX)
        self.k_clamped = body.k > K_MAX
        sb.pull = 1.0 - 1.0 / (1.0 + k)
        sb.push = sb.pull
        sb.damping = float(o["damping"])
        sb.plastic = 0
        sb.use_self_collision = False
        sb.step_min = int(o["step_min"])
        sb.step_max = int(o["step_max"])
        sb.use_auto_step = False
        sb.error_threshold = float(o["error_threshold"])
        if body.pinned.any():
            vg = obj.vertex_groups.new(name="pin")
            vg.add([int(i) for i in np.flatnonzero(body.pinned)], 1.0, "REPLACE")
            sb.use_goal = True
            sb.vertex_group_goal = "pin"
            sb.goal_min = 0.0
            sb.goal_max = 1.0
            # Blender multiplies goal_default by the group weight (1 pinned, 0 = not in the group);
            # a goal >= 0.999 snaps the vertex onto its rest position (SOFTGOALSNAP)
            sb.goal_default = 1.0
        else:
            sb.use_goal = False
        sb.effector_weights.gravity = 1.0
        cache = mod.point_cache
        cache.frame_start = 1
        cache.frame_end = 1_000_000
        return obj

    def _add_cloth(self, name: str, idx: np.ndarray, xb: np.ndarray, mat, fixed: np.ndarray) -> _Body:
        bpy, o, s = self.bpy, self.options, self.setup
        sheet, quad, w, d = build_sheet(xb, o["cells_across"])
        me = bpy.data.meshes.new(name)
        me.from_pydata(sheet.vertices.tolist(), [], sheet.quads.tolist())
        me.update()
        obj = bpy.data.objects.new(name, me)
        bpy.context.scene.collection.objects.link(obj)
        pinned = np.zeros(len(sheet.vertices), dtype=bool)
        if fixed.any():
            pinned[np.unique(sheet.quads[quad[fixed]])] = True
            for bd in s.boundaries:
                if bd.kind == "fixed_region":
                    pinned |= np.all((sheet.vertices >= np.asarray(bd.lo)) & (sheet.vertices <= np.asarray(bd.hi)), axis=1)
        mod = obj.modifiers.new("cloth", "CLOTH")
        cs = mod.settings
        total = float(mat.rho * s.p_vol[idx].sum())
        # Blender cloth has one mass per vertex; light vertices (~0.02) fall 10 % slow in free fall
        # (measured, Blender 5.0.1), so the vertex mass total / n_vertices kg is the mass unit
        # (cs.mass = 1) and tension/bending are in Blender units relative to it
        mu = total / len(sheet.vertices)
        cs.mass = 1.0
        cs.time_scale = self.speed                  # cloth is frame based like soft bodies: same clock
        cs.quality = int(o["step_min"])
        cs.air_damping = 0.0
        cs.tension_stiffness = cs.compression_stiffness = cs.shear_stiffness = float(o["tension"])
        cs.bending_stiffness = float(o["bending"])
        if pinned.any():
            vg = obj.vertex_groups.new(name="pin")
            vg.add([int(i) for i in np.flatnonzero(pinned)], 1.0, "REPLACE")
            cs.vertex_group_mass = "pin"            # Blender's cloth pin group
        col = mod.collision_settings
        col.use_collision = True
        col.use_self_collision = False
        col.distance_min = float(o["thickness"])
        friction = [bd.friction for bd in s.boundaries if bd.kind == "ground"]
        if friction:
            col.friction = float(min(80.0, friction[0]))
        mod.point_cache.frame_start = 1
        mod.point_cache.frame_end = 1_000_000
        body = _Body(idx, None, quad, w, pinned, mu, float(o["tension"]), 0.0, None)
        body.sheet, body.d = sheet, d
        body.obj = obj
        return body

    def _add_ground(self, bd) -> None:
        bpy, s = self.bpy, self.setup
        half = 2.0 * float(np.max(s.domain_hi - s.domain_lo)) + 10.0
        c = 0.5 * (s.domain_lo + s.domain_hi)
        z = float(bd.height)
        verts = [(c[0] - half, c[1] - half, z), (c[0] + half, c[1] - half, z),
                 (c[0] + half, c[1] + half, z), (c[0] - half, c[1] + half, z)]
        me = bpy.data.meshes.new("gasp_ground")
        me.from_pydata(verts, [], [(0, 1, 2, 3)])
        me.update()
        obj = bpy.data.objects.new("gasp_ground", me)
        bpy.context.scene.collection.objects.link(obj)
        obj.modifiers.new("collision", "COLLISION")
        col = obj.collision
        col.use = True
        col.damping = float(self.options["collision_damping"])
        col.thickness_outer = float(self.options["thickness"])
        col.cloth_friction = float(min(80.0, bd.friction))  # cloth only (soft bodies have no friction)

    # ------------------------------------------------------------------ stepping
    def _read_positions(self) -> np.ndarray:
        x = np.empty((self.n_points, 3))
        for body in self.bodies:
            ev = body.obj.evaluated_get(self.depsgraph)
            me = ev.to_mesh()
            co = np.empty(3 * len(me.vertices), dtype=np.float32)
            me.vertices.foreach_get("co", co)
            ev.to_mesh_clear()
            verts = co.reshape(-1, 3).astype(np.float64)
            if body.cage is None:
                x[body.idx] = place(verts, body.sheet, body.cell, body.w, body.d)
            else:
                x[body.idx] = interpolate(verts, body.cage, body.cell, body.w)
        return x

    def step_frame(self) -> None:
        """Advance by ``frame_dt``: ``scene.frame_set(frame + 1)`` and read the cage back.

        Raises
        ------
        EngineDivergence
            Non-finite positions or a point leaving the domain
            (:func:`gasp_core.seam.runner.check_state`).
        """
        if _OWNER is not self:
            raise EngineError(f"engine '{ENGINE}': this simulation's Blender scene was replaced by another "
                              "'blender' engine built in the same process (bpy has one scene per process)")
        self.frame += 1
        scene = self.bpy.context.scene
        scene.frame_set(self.frame + 1)
        self.depsgraph = self.bpy.context.evaluated_depsgraph_get()
        x = self._read_positions()
        s = self.setup
        check_state(x, s, self.frame)  # the core's blow-up check, before the velocity is derived
        self._v = (x - self._x) / s.frame_dt
        self._x = x

    def positions(self) -> np.ndarray:
        """Point positions, shape (n, 3), float64 (from Blender's float32), metres."""
        return self._x.copy()

    def velocities(self) -> np.ndarray:
        """Backward-difference point velocities over the last frame, shape (n, 3), m/s."""
        return self._v.copy()

    def stats(self) -> dict[str, Any]:
        """device, precision, n_points, cage sizes, Blender settings derived from the material."""
        return {
            "device": "cpu", "precision": "f32", "n_points": self.n_points, "frame": self.frame,
            "mode": self.options["mode"], "speed": self.speed,
            "n_cage_vertices": int(sum(len(b.cage.vertices) if b.cage is not None else len(b.sheet.vertices)
                                       for b in self.bodies)),
            "n_springs": int(sum(len(b.cage.edges) for b in self.bodies if b.cage is not None)),
            "cell_size": [b.cage.h if b.cage is not None else b.sheet.h for b in self.bodies],
            "mass_unit_kg": [b.mu for b in self.bodies],
            "spring_k_blender": [b.k for b in self.bodies],
            "spring_k_clamped": [bool(b.k > K_MAX) for b in self.bodies],
            "step_min": self.options["step_min"], "step_max": self.options["step_max"],
            "blender": ".".join(map(str, self.bpy.app.version)),
            **self._mass_properties(),
        }

    def _mass_properties(self) -> dict[str, Any]:
        """``mass`` (kg) and ``centre_of_mass`` (m) of the cage or sheet vertices Blender simulates,
        at their rest positions (node masses as lumped, after Blender's 1 % floor); nothing in cloth
        mode, whose sheet takes Blender's uniform vertex mass."""
        if any(b.mass_kg is None for b in self.bodies):
            return {}
        m = [np.asarray(b.mass_kg, float) for b in self.bodies]
        v = [b.cage.vertices if b.cage is not None else b.sheet.vertices for b in self.bodies]
        total = float(sum(mi.sum() for mi in m))
        if total <= 0.0:
            return {}
        com = sum(mi @ vi for mi, vi in zip(m, v)) / total
        return {"mass": total, "centre_of_mass": [float(c) for c in com]}

    def close(self) -> None:
        """Empty the Blender scene (if this engine still owns it)."""
        global _OWNER
        if _OWNER is self:
            self.bpy.ops.wm.read_factory_settings(use_empty=True)
            _OWNER = None
        self.bodies = []
