"""The ``mujoco_flex`` engine: one MuJoCo model built from a :class:`~gasp_core.seam.engine.SimSetup`.

Per body (``setup.body_id``):

* ``jelly`` / ``metal``: a coarse conforming tetrahedral lattice (:mod:`.lattice`) emitted as
  ``<flexcomp type="direct" dim="3">`` with ``<elasticity young=E poisson=nu damping=...>``
  (MuJoCo's Saint Venant-Kirchhoff flex FEM). ``metal`` adds ``yield = yield_stress / E``
  (MuJoCo 4 flex von Mises plasticity on the elastic stretching strain). Vertex masses are lumped
  from ``rho`` and the tet volumes. Points ride on their tet with fixed barycentric weights.
* ``rigid``: a free body made of one box geom per occupied lattice cell (``density = rho``);
  points follow the body pose.

Boundaries: ``ground`` is a plane geom at ``z = height`` with the boundary's friction;
``fixed_region`` pins (flexcomp ``<pin id>``) every lattice vertex of a tet that holds a point
inside the box, so those points stay exactly still; a rigid body with a point in the box gets no
free joint.

MuJoCo 4 rejects flex elasticity under ``implicit`` / ``implicitfast`` ("flex elasticity is no
longer integrated implicitly ... set integrator='discrete', or 'Euler' with a small timestep"),
so the default integrator is ``discrete`` (implicit in position; CG/Newton solver required).

Sources: MuJoCo XML reference (``flexcomp``, ``flex/elasticity``, ``flex/contact``,
``option/integrator``) and Computation chapter (discrete integrator), MuJoCo 4.0.0.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

import mujoco

from gasp_core.seam import CAUSE_UNSTABLE, check_state, EngineDivergence, EngineError, SceneError, SimSetup
from gasp_core.mpm.points import fixed_mask
from gasp_core.mpm.substeps import p_wave_speed, substeps_for

from . import ENGINE
from .lattice import Lattice, build_lattice, embed_points, interpolate, matched_masses

_WARN_NAMES = {
    int(mujoco.mjtWarning.mjWARN_INERTIA): "singular inertia",
    int(mujoco.mjtWarning.mjWARN_CONTACTFULL): "contact buffer full",
    int(mujoco.mjtWarning.mjWARN_CNSTRFULL): "constraint buffer full",
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "bad number in qpos",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "bad number in qvel",
    int(mujoco.mjtWarning.mjWARN_BADQACC): "bad number in qacc (mjWARN_BADQACC)",
    int(mujoco.mjtWarning.mjWARN_BADCTRL): "bad number in ctrl",
}


def _fmt(a) -> str:
    return " ".join(f"{v:.17g}" for v in np.asarray(a, dtype=np.float64).ravel())


def _ifmt(a) -> str:
    return " ".join(str(int(v)) for v in np.asarray(a).ravel())


class _FlexBody:
    """Bookkeeping of one deformable body: lattice, embedding, MuJoCo ids."""

    def __init__(self, name: str, idx: np.ndarray, lat: Lattice, tet: np.ndarray, w: np.ndarray,
                 pinned: np.ndarray, rho: float):
        self.name, self.idx, self.lat, self.tet, self.w = name, idx, lat, tet, w
        self.pinned = pinned            # (n_vertices,) bool
        self.rho = rho
        self.flex_id = -1
        self.vert_adr = 0
        self.vert_body = np.zeros(0, np.int64)   # MuJoCo body id of each vertex
        self.vert_dof = np.zeros(0, np.int64)    # first dof of each unpinned vertex, -1 if pinned
        self.vertex_mass = np.zeros(0)           # kg, Lattice.matched_masses
        self.stiffness_scale = 1.0               # E' / E = the points' mass / the lattice's at rho


class _RigidBody:
    """Bookkeeping of one rigid body: MuJoCo body id and the points in the body frame."""

    def __init__(self, name: str, idx: np.ndarray, com: np.ndarray, local: np.ndarray, fixed: bool):
        self.name, self.idx, self.com, self.local, self.fixed = name, idx, com, local, fixed
        self.body_id = -1
        self.dof = -1


class MujocoFlexEngine:
    """A running MuJoCo flex simulation of a :class:`~gasp_core.seam.engine.SimSetup`.

    Parameters
    ----------
    setup : SimSetup
        World frame, metres, z up. ``setup.options`` holds every option of
        :data:`gasp_mujoco_flex.OPTIONS`. Options, materials and boundaries are checked (options
        completed) by the core (``gasp_core.seam.build.build_engine``).

    Raises
    ------
    SceneError
        Unknown option or bad option value. (``nu < 0`` and ``metal`` without a yield stress are
        refused by the core, from :data:`gasp_mujoco_flex.LIMITS`.)
    EngineError
        MuJoCo rejects the generated model (the message quotes MuJoCo's error).

    Notes
    -----
    ``step_frame`` runs ``n_substeps = ceil(frame_dt / dt)`` calls of ``mj_step`` with
    ``dt = frame_dt / n_substeps``. Divergence is detected from MuJoCo's warning counters
    (``mjData.warning``; MuJoCo resets the state itself on a bad ``qacc``), non-finite state, tets
    stretched beyond ``max_strain`` or inverted, and points leaving ``[domain_lo, domain_hi]``.
    """

    def __init__(self, setup: SimSetup):
        self.setup = setup
        o = setup.options  # checked and completed by the core (build_engine)
        self.options = o
        # nu >= 0 and the metal's yield stress > 0 are declared as data (gasp_mujoco_flex.LIMITS)
        # and checked by the core before the factory runs.
        self.frame = 0
        self.n_points = len(setup.x)
        self._build()

    # ------------------------------------------------------------------ model construction
    def _build(self) -> None:
        """Build the MuJoCo model and data: one XML part per body, the time step, the compiled model with
        its ids bound to the bodies, then the initial state."""
        s = self.setup
        self.flex: list[_FlexBody] = []
        self.rigid: list[_RigidBody] = []
        parts = []
        fixed_pt = fixed_mask(s.x, s.boundaries)
        h_min = math.inf
        wave = 1.0
        for b, mat in enumerate(s.materials):
            idx = np.flatnonzero(s.body_id == b)
            if len(idx) == 0:
                continue
            h = self._cell_size(idx)
            lat = build_lattice(s.x[idx], h)
            if mat.name == "rigid":
                parts.append(self._rigid_xml(f"b{b}", idx, lat, h, fixed_pt))
            else:
                h_min = min(h_min, h)
                xml, wave_factor = self._flex_xml(f"b{b}", idx, lat, h, mat, fixed_pt)
                wave = max(wave, wave_factor)
                parts.append(xml)
        self.n_substeps, self.dt = self._time_step(h_min, wave)
        self.xml = self._model_xml(parts)
        try:
            self.model = mujoco.MjModel.from_xml_string(self.xml)
        except ValueError as e:
            raise EngineError(f"engine '{ENGINE}': MuJoCo rejected the generated model: {e}") from e
        self._bind_flex_bodies()
        for rb in self.rigid:
            rb.body_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, rb.name)
            rb.dof = -1 if rb.fixed else int(self.model.body_dofadr[rb.body_id])
        self._initial_state()

    def _cell_size(self, idx: np.ndarray) -> float:
        """Lattice cell side (m) of the body made of points ``idx``: option ``cell_size``, else the body's
        size over ``cells_across``."""
        s, o = self.setup, self.options
        xb = s.x[idx]
        ext = float(np.max(xb.max(0) - xb.min(0)))
        # the body's size is at least the side of the volume one point stands for (a single point
        # had 1e-6 m / cells_across cells, with its real mass: millions of substeps a frame)
        size = max(ext, float(np.mean(s.p_vol[idx])) ** (1.0 / 3.0), 1e-6)
        return float(o["cell_size"]) if o["cell_size"] is not None else size / float(o["cells_across"])

    def _rigid_xml(self, name: str, idx: np.ndarray, lat: Lattice, h: float, fixed_pt: np.ndarray) -> str:
        """``<body>`` of a rigid body: one box geom per occupied cell; appends its :class:`_RigidBody`."""
        s = self.setup
        xb, pm = s.x[idx], s.p_mass[idx]
        centres = lat.origin + (lat.cells + 0.5) * h
        com = centres.mean(axis=0)
        # the points' mass and centre of mass, spread on the cells (lattice.matched_masses)
        m_box = matched_masses(np.full(len(centres), h ** 3), centres, float(pm.sum()), pm @ xb / pm.sum())
        rb = _RigidBody(name, idx, com, xb - com, bool(fixed_pt[idx].any()))
        geoms = "\n".join(
            f'<geom type="box" size="{h / 2:.17g} {h / 2:.17g} {h / 2:.17g}" pos="{_fmt(c - com)}" '
            f'density="{mb / h ** 3:.17g}"/>' for c, mb in zip(centres, m_box))
        joint = "" if rb.fixed else "<freejoint/>"
        self.rigid.append(rb)
        return f'<body name="{name}" pos="{_fmt(com)}">{joint}\n{geoms}\n</body>'

    def _pinned_vertices(self, lat: Lattice, tet: np.ndarray, fixed_in_body: np.ndarray) -> np.ndarray:
        """(n_vertices,) bool: the lattice vertices of a tet holding a fixed point, and those inside a
        ``fixed_region`` box."""
        pinned = np.zeros(len(lat.vertices), dtype=bool)
        if fixed_in_body.any():
            pinned[np.unique(lat.tets[tet[fixed_in_body]])] = True
            for bd in self.setup.boundaries:
                if bd.kind == "fixed_region":
                    pinned |= np.all((lat.vertices >= np.asarray(bd.lo)) &
                                     (lat.vertices <= np.asarray(bd.hi)), axis=1)
        return pinned

    def _flex_xml(self, name: str, idx: np.ndarray, lat: Lattice, h: float, mat,
                  fixed_pt: np.ndarray) -> tuple[str, float]:
        """``(<flexcomp> xml, wave-speed factor)`` of a deformable body; appends its :class:`_FlexBody`.

        The factor (>= 1 where vertices are lighter than their lumped share) multiplies the body's
        P-wave speed in the time-step estimate.
        """
        s, o = self.setup, self.options
        xb, pm = s.x[idx], s.p_mass[idx]
        tet, w = embed_points(lat, xb)
        pinned = self._pinned_vertices(lat, tet, fixed_pt[idx])
        fb = _FlexBody(name, idx, lat, tet, w, pinned, mat.rho)
        # Vertex masses carry the points' total mass and centre of mass (Lattice.matched_masses).
        # The lattice covers more (or less) than the solid: the points' mass is r = M / (rho V_lat)
        # of the lattice's. Spread on the lattice at density r rho, the solid keeps its wave speed
        # and its sag under its own weight (rho g L^2 / E) with E' = r E (yield strain kept), and
        # M + dt^2 K is r times that of the unscaled lattice: lighter vertices with the full E
        # left MuJoCo's M+K solve ill-conditioned. Where the centre-of-mass reweighting makes a
        # vertex lighter than r times its lumped mass, waves speed up by sqrt(ratio).
        M = float(pm.sum())
        r = M / (mat.rho * lat.volume)
        fb.vertex_mass = lat.matched_masses(mat.rho, M, pm @ xb / M)
        fb.stiffness_scale = r
        wave_factor = math.sqrt(float(np.max(r * lat.vertex_masses(mat.rho) / fb.vertex_mass)))
        radius = float(o["radius"]) if o["radius"] is not None else 0.05 * h
        elastic = (f'young="{r * mat.E:.17g}" poisson="{mat.nu:.17g}" '
                   f'damping="{float(o["damping"]):.17g}"')
        if mat.name == "metal":
            elastic += f' yield="{mat.yield_stress / mat.E:.17g}"'
        pin = f'<pin id="{_ifmt(np.flatnonzero(pinned))}"/>' if pinned.any() else ""
        self.flex.append(fb)
        return (f'<flexcomp name="{name}" type="direct" dim="3" radius="{radius:.17g}" mass="{M:.17g}" '
                f'point="{_fmt(lat.vertices)}" element="{_ifmt(lat.tets)}">\n'
                f'<elasticity {elastic}/>\n'
                f'<contact selfcollide="none" friction="{self._ground_friction():.17g}"/>\n'
                f'{pin}</flexcomp>'), wave_factor

    def _time_step(self, h_min: float, wave: float) -> tuple[int, float]:
        """``(n_substeps, dt)``: an elastic-wave (CFL) estimate over the deformable bodies (smallest cell
        ``h_min``, wave-speed factor ``wave``), bounded by option ``dt_max``; option ``dt`` overrides it.

        Raises SceneError when option ``dt`` exceeds ``frame_dt``.
        """
        s, o = self.setup, self.options
        v0 = float(np.max(np.linalg.norm(s.v, axis=1))) if len(s.v) else 0.0
        height = float(s.domain_hi[2] - s.domain_lo[2])
        v_fall = v0 + math.sqrt(2.0 * float(np.linalg.norm(s.gravity)) * max(height, 0.0))
        dt_max = float(o["dt_max"])
        if self.flex:
            c = max(p_wave_speed(m) for m in s.materials if m.name != "rigid") * wave
            dt_max = min(dt_max, float(o["cfl"]) * h_min / max(c, v_fall, 1e-12))
        if o["dt"] is not None:
            dt_max = float(o["dt"])
        if o["dt"] is not None and float(o["dt"]) > s.frame_dt * (1 + 1e-9):
            raise SceneError(f"engine '{ENGINE}': option dt={o['dt']!r} s is longer than frame_dt="
                             f"{s.frame_dt!r} s; expected 0 < dt <= frame_dt")
        return substeps_for(s.frame_dt, dt_max)

    def _model_xml(self, parts: list[str]) -> str:
        """The whole MJCF: options (``self.dt``), ground planes, static colliders and the bodies' ``parts``."""
        s, o = self.setup, self.options
        ground = ""
        for bd in s.boundaries:
            if bd.kind == "ground":
                ground += (f'<geom name="ground" type="plane" size="0 0 1" pos="0 0 {bd.height:.17g}" '
                           f'friction="{bd.friction:.17g} 0.005 0.0001"/>\n')
        g = _fmt(s.gravity)
        from .colliders import collider_xml
        col_asset, col_bodies = collider_xml(s.colliders, ENGINE)
        size = f'<size memory="{o["memory"]}"/>\n' if o.get("memory") else ""
        return (f'<mujoco model="gasp_mujoco_flex">\n'
                f'<compiler angle="radian"/>\n{size}{col_asset}'
                f'<option timestep="{self.dt:.17g}" gravity="{g}" integrator="{o["integrator"]}" '
                f'solver="{o["solver"]}" iterations="{int(o["iterations"])}" cone="pyramidal"/>\n'
                f'<worldbody>\n{ground}{col_bodies}\n' + "\n".join(parts) + '\n</worldbody>\n</mujoco>')

    def _bind_flex_bodies(self) -> None:
        """Each flex body's MuJoCo ids (flex, vertex bodies, dofs); the lattice's lumped vertex masses and
        inertias replace flexcomp's equal split."""
        m = self.model
        for fb in self.flex:
            fb.flex_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, fb.name)
            fb.vert_adr = int(m.flex_vertadr[fb.flex_id])
            nv = int(m.flex_vertnum[fb.flex_id])
            if nv != len(fb.lat.vertices):
                raise EngineError(f"engine '{ENGINE}': flex {fb.name} has {nv} vertices, "
                                  f"expected {len(fb.lat.vertices)}")
            fb.vert_body = m.flex_vertbodyid[fb.vert_adr:fb.vert_adr + nv].astype(np.int64)
            fb.vert_dof = np.where(fb.pinned, -1, m.body_dofadr[fb.vert_body]).astype(np.int64)
            # lumped masses (rho V_tet / 4 per incident tet, reweighted to the points' mass and centre
            # of mass: Lattice.matched_masses) replace flexcomp's equal split
            vm = fb.vertex_mass
            free = ~fb.pinned
            m.body_mass[fb.vert_body[free]] = vm[free]
            edge = fb.lat.h
            m.body_inertia[fb.vert_body[free]] = (vm[free] * edge ** 2 / 6.0)[:, None] * np.ones(3)

    def _initial_state(self) -> None:
        """``self.data`` with the constants, initial velocities and forward pass; MuJoCo warnings raised
        meanwhile are kept for frame 1; the warning counters and rest edge lengths are recorded."""
        m = self.model
        self.data = mujoco.MjData(m)
        self._pending: list[str] = []      # MuJoCo warnings raised while building, reported by frame 1
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self._pending.append)
        try:
            mujoco.mj_setConst(m, self.data)
            self._set_initial_velocity()
            mujoco.mj_forward(m, self.data)
        finally:
            mujoco.set_mju_user_warning(previous)
        self._warn0 = np.array([w.number for w in self.data.warning])
        self._rest_edge = [self._edge_lengths(fb, fb.lat.vertices) for fb in self.flex]

    def _ground_friction(self) -> float:
        for b in self.setup.boundaries:
            if b.kind == "ground":
                return float(b.friction)
        return 0.5

    def _set_initial_velocity(self) -> None:
        s, d = self.setup, self.data
        for fb in self.flex:
            v = s.v[fb.idx]
            n_v = len(fb.lat.vertices)
            num = np.zeros((n_v, 3))
            den = np.zeros(n_v)
            verts = fb.lat.tets[fb.tet]                             # (n, 4)
            w = np.clip(fb.w, 0.0, None)
            np.add.at(num, verts.ravel(), (w[:, :, None] * v[:, None, :]).reshape(-1, 3))
            np.add.at(den, verts.ravel(), w.ravel())
            vmean = v.mean(axis=0)
            vv = np.where(den[:, None] > 0, num / np.maximum(den, 1e-300)[:, None], vmean)
            for k in np.flatnonzero(~fb.pinned):
                d.qvel[fb.vert_dof[k]:fb.vert_dof[k] + 3] = vv[k]
        for rb in self.rigid:
            if rb.fixed:
                continue
            v = s.v[rb.idx]
            r = rb.local
            # least squares v_i = v0 + w x r_i
            A = np.zeros((3 * len(r), 6))
            A[:, :3] = np.tile(np.eye(3), (len(r), 1))
            cx = np.zeros((len(r), 3, 3))
            cx[:, 0, 1], cx[:, 0, 2] = r[:, 2], -r[:, 1]
            cx[:, 1, 0], cx[:, 1, 2] = -r[:, 2], r[:, 0]
            cx[:, 2, 0], cx[:, 2, 1] = r[:, 1], -r[:, 0]
            A[:, 3:] = cx.reshape(-1, 3)          # -[r]_x w = w x r
            sol = np.linalg.lstsq(A, v.ravel(), rcond=None)[0]
            d.qvel[rb.dof:rb.dof + 3] = sol[:3]
            d.qvel[rb.dof + 3:rb.dof + 6] = sol[3:]   # body frame == world frame at rest

    @staticmethod
    def _edge_lengths(fb: _FlexBody, verts: np.ndarray) -> np.ndarray:
        t = fb.lat.tets
        pairs = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
        return np.stack([np.linalg.norm(verts[t[:, a]] - verts[t[:, b]], axis=1) for a, b in pairs], 1)

    # ------------------------------------------------------------------ stepping
    def step_frame(self) -> None:
        """Advance by ``frame_dt``: ``n_substeps`` calls of ``mj_step``, then ``mj_fwdKinematics`` so that
        positions (``flexvert_xpos``, ``xpos``, ``xmat``) belong to the final ``qpos``, as velocities do.

        Raises
        ------
        EngineDivergence
            On a MuJoCo warning or fatal error during a step, non-finite state, an inverted or
            over-stretched tet, or a point leaving the domain.
        """
        self.frame += 1
        m, d = self.model, self.data
        messages: list[str] = self._pending
        self._pending = []
        previous = mujoco.get_mju_user_warning()
        # collect MuJoCo's warning text instead of letting it print and write MUJOCO_LOG.TXT
        mujoco.set_mju_user_warning(messages.append)
        try:
            for _ in range(self.n_substeps):
                try:
                    mujoco.mj_step(m, d)
                except mujoco.FatalError as e:  # mju_error inside a step of a model that compiled
                    raise EngineDivergence(f"MuJoCo stopped at t = {d.time:.6g} s: {e}", self.frame,
                                           cause=f"time step too large for the stiffness (dt = {self.dt:.3g} s) "
                                                 "or stiffness too high") from e
                counts = np.array([w.number for w in d.warning])
                if np.any(counts > self._warn0) or messages:
                    self._raise_warning(counts, messages)
        finally:
            mujoco.set_mju_user_warning(previous)
        if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            raise EngineDivergence(f"non-finite MuJoCo state (dt = {self.dt:.3g} s)", self.frame, CAUSE_UNSTABLE)
        # mj_step computes xpos / xmat / flexvert_xpos from qpos *before* it integrates, so after
        # the loop they are one substep old while qvel is current; recompute them from the new qpos
        # (kinematics, comPos, flex, tendon; no collision or dynamics, so the next mj_step is unchanged)
        mujoco.mj_fwdKinematics(m, d)
        self._check_lattice()
        check_state(self.positions(), self.setup, self.frame)  # the core's blow-up check

    def _raise_warning(self, counts: np.ndarray, messages: list[str]) -> None:
        """Raise :class:`EngineDivergence` for a MuJoCo warning, naming its likely cause: a full contact or
        constraint buffer means too many contacts (bodies overlapping, at the start when it is the first
        substep), anything else a step too large for the stiffness."""
        d = self.data
        bad = np.flatnonzero(counts > self._warn0)
        code = int(bad[0]) if len(bad) else -1
        what = _WARN_NAMES.get(code, str(code) if code >= 0 else "warning")
        text = " ".join(m_.strip().split(". Increase arena memory")[0].rstrip(".") for m_ in messages)
        cause = f"time step too large for the stiffness (dt = {self.dt:.3g} s) or stiffness too high"
        full = {int(mujoco.mjtWarning.mjWARN_CONTACTFULL), int(mujoco.mjtWarning.mjWARN_CNSTRFULL)}
        if code in full or "arena memory" in text:
            first = self.frame == 1 and d.time <= 1.5 * self.dt
            cause = ((("bodies that overlap at the start (two objects, or an object and a collider, in the "
                       "same place)" if first else "more contacts than MuJoCo's arena holds (bodies pressed "
                       "into each other)"))
                     + "; move the objects apart, or raise the engine option memory (MuJoCo's <size memory>, "
                       f"now {self.options.get('memory') or 'its default'}), e.g. memory = \"1G\"")
        raise EngineDivergence(f"MuJoCo {what} at t = {d.time:.6g} s" + (f": {text}" if text else ""),
                               self.frame, cause=cause)

    def _check_lattice(self) -> None:
        d = self.data
        for fb, rest in zip(self.flex, self._rest_edge):
            verts = d.flexvert_xpos[fb.vert_adr:fb.vert_adr + len(fb.lat.vertices)]
            ratio = self._edge_lengths(fb, verts) / rest
            if ratio.max() > 1.0 + float(self.options["max_strain"]):
                raise EngineDivergence(
                    f"lattice {fb.name}: a tet edge is stretched {ratio.max():.3g} x its rest length",
                    self.frame, cause=f"time step too large (dt = {self.dt:.3g} s) or stiffness too high")
            V = verts[fb.lat.tets]
            vol = np.einsum("ij,ij->i", np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]), V[:, 3] - V[:, 0])
            V0 = fb.lat.vertices[fb.lat.tets]
            vol0 = np.einsum("ij,ij->i", np.cross(V0[:, 1] - V0[:, 0], V0[:, 2] - V0[:, 0]), V0[:, 3] - V0[:, 0])
            inverted = vol * vol0 <= 0
            if inverted.any():
                raise EngineDivergence(
                    f"lattice {fb.name}: {int(inverted.sum())} tetrahedra inverted", self.frame,
                    cause=f"time step too large (dt = {self.dt:.3g} s), stiffness too low for the load, "
                          "or a too coarse lattice")

    # ------------------------------------------------------------------ output
    def positions(self) -> np.ndarray:
        """Point positions, shape (n, 3), float64, metres, in the order of ``setup.x``."""
        d = self.data
        x = np.empty((self.n_points, 3))
        for fb in self.flex:
            verts = d.flexvert_xpos[fb.vert_adr:fb.vert_adr + len(fb.lat.vertices)]
            x[fb.idx] = interpolate(verts, fb.lat.tets, fb.tet, fb.w)
        for rb in self.rigid:
            R = d.xmat[rb.body_id].reshape(3, 3)
            x[rb.idx] = d.xpos[rb.body_id] + rb.local @ R.T
        return x

    def velocities(self) -> np.ndarray:
        """Point velocities, shape (n, 3), float64, m/s."""
        d = self.data
        v = np.zeros((self.n_points, 3))
        for fb in self.flex:
            vv = np.zeros((len(fb.lat.vertices), 3))
            free = fb.vert_dof >= 0
            dof = fb.vert_dof[free]
            vv[free] = d.qvel[dof[:, None] + np.arange(3)]
            v[fb.idx] = interpolate(vv, fb.lat.tets, fb.tet, fb.w)
        for rb in self.rigid:
            if rb.fixed:
                continue
            R = d.xmat[rb.body_id].reshape(3, 3)
            lin = d.qvel[rb.dof:rb.dof + 3]
            ang = R @ d.qvel[rb.dof + 3:rb.dof + 6]
            v[rb.idx] = lin + np.cross(ang, rb.local @ R.T)
        return v

    def stats(self) -> dict[str, Any]:
        """Run figures: device, precision, n_points, lattice sizes, dt, n_substeps, sim_time."""
        return {
            "device": "cpu",
            "precision": "f64",
            "n_points": self.n_points,
            "n_lattice_vertices": int(sum(len(fb.lat.vertices) for fb in self.flex)),
            "n_tets": int(sum(len(fb.lat.tets) for fb in self.flex)),
            "n_rigid_boxes": int(sum(int(self.model.body_geomnum[rb.body_id]) for rb in self.rigid)),
            "cell_size": [fb.lat.h for fb in self.flex],
            "dt": self.dt,
            "n_substeps": self.n_substeps,
            "frame": self.frame,
            "sim_time": float(self.data.time),
            "integrator": self.options["integrator"],
            "nv": int(self.model.nv),
            "stiffness_scale": [float(fb.stiffness_scale) for fb in self.flex],   # E' / E per flex body
            **self._mass_stats(),
        }

    def _mass_stats(self) -> dict[str, Any]:
        """Mass, centre of mass and inertia of what MuJoCo simulates (flex vertices and rigid bodies)."""
        from gasp_core.seam.passive import mass_properties
        m, d = self.model, self.data
        xs, ms = [], []
        for fb in self.flex:
            free = ~fb.pinned
            xs.append(d.flexvert_xpos[fb.vert_adr:fb.vert_adr + len(fb.lat.vertices)][free])
            ms.append(m.body_mass[fb.vert_body[free]])
            if fb.pinned.any():   # pinned vertices are not bodies: their share of the points' mass
                xs.append(fb.lat.vertices[fb.pinned])
                ms.append(fb.vertex_mass[fb.pinned])
        for rb in self.rigid:
            xs.append(d.xipos[rb.body_id][None])
            ms.append(np.array([m.body_subtreemass[rb.body_id]]))
        return mass_properties(np.concatenate(xs), np.concatenate(ms))

    def close(self) -> None:
        """Drop the MuJoCo model and data."""
        self.model = None
        self.data = None
