"""The Newton implicit-MPM engine: :class:`NewtonEngine`, built from a :class:`~gasp_core.seam.SimSetup`.

Wraps ``newton.solvers.SolverImplicitMPM`` (Newton 1.8.0, Apache-2.0): particles from ``SimSetup``
(``ModelBuilder.add_particles``; Newton takes a particle's volume as ``(2 r)^3``, so ``r = p_vol^(1/3) / 2``
gives back ``p_vol`` and the mass ``rho p_vol``), per-particle materials (:mod:`gasp_newton.materials`),
the ground as Newton's ground plane and the walls as five more planes, each with the boundary's Coulomb
friction, ``fixed_region`` points as zero-mass (kinematic) particles, ``SimSetup.C`` as the particles'
APIC velocity gradient. ``n_substeps`` implicit steps per frame, each followed by Newton's
``project_outside`` (points pushed out of the colliders).

Warp's output is kept off stdout: module-load lines (which the engine reads to time kernel compilation,
``stats()["compile_s"]``) and Newton's solver log (which it reads for the rheology residual) are
captured, and the "no CUDA driver" warning of ``wp.init()`` on a CPU-only machine is dropped.
"""
from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import re
import sys
import tempfile
import time
from typing import Any

import numpy as np

from gasp_core.mpm.points import engine_mass_stats, fixed_mask
from gasp_core.seam import EngineDivergence, EngineError, SceneError, SimSetup

from .materials import FIELDS, particle_parameters

#: Newton's logger of the rheology solve (its residual lines are read, never printed).
_SOLVE_LOGGER = "newton._src.solvers.implicit_mpm.solve_rheology"
_LOAD_LINE = re.compile(r"^Module .* took ([0-9.]+) ms\s+\((compiled|cached)\)")
#: Causes of a divergence this engine detects itself.
CAUSE_NO_CONVERGENCE = ("the implicit rheology solve did not converge (non-finite residual): material too "
                        "stiff or too soft for the step and voxel size; raise n_substeps or max_iterations")
#: The state arrays of ``get_state`` besides ``frame`` and ``sim_time``.
STATE_KEYS = ("x", "v", "C", "F_e", "Jp", "stress")


def init_warp(cpu_only: bool) -> None:
    """``wp.init()`` with its output kept off stdout: the native "CUDA driver" warning of a machine without GPU
    is dropped (on a CUDA run the engine refuses in its own one line), on a CPU run any other CUDA line too;
    every other line goes to stderr."""
    import warp as wp
    with tempfile.TemporaryFile(mode="w+b") as cap:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = os.dup(1), os.dup(2)
        os.dup2(cap.fileno(), 1)
        os.dup2(cap.fileno(), 2)
        level = wp.config.log_level
        try:
            wp.config.log_level = max(level, wp.LOG_WARNING)    # no banner
            with contextlib.redirect_stdout(sys.stderr):         # Python-level lines, if any
                wp.init()
        finally:
            wp.config.log_level = level
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        cap.seek(0)
        for line in cap.read().decode(errors="replace").splitlines():
            if not ("CUDA driver" in line or (cpu_only and "CUDA" in line)):
                print(line, file=sys.stderr)


class _Capture(logging.Handler):
    """Collects Warp's module-load times (stdout lines) and Newton's residual log records."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.compile_s = self.load_s = 0.0
        self.n_compiled = 0
        self.last = None     # (iterations, res_l2, res_linf) of the last solve batch

    def emit(self, record):
        args = record.args if isinstance(record.args, tuple) else ()
        if len(args) == 4:  # "%s iteration #%s res(l2)=%s, res(linf)=%s" or "terminated after"
            self.last = (int(args[1]), float(args[2]), float(args[3]))

    @contextlib.contextmanager
    def watching(self):
        import warp as wp
        buf = io.StringIO()
        log = logging.getLogger(_SOLVE_LOGGER)
        level, propagate = log.level, log.propagate
        log.addHandler(self)
        log.setLevel(logging.INFO)
        log.propagate = False
        saved_level = wp.config.log_level
        wp.config.log_level = wp.LOG_INFO       # module loads print "... took X ms (compiled)"
        try:
            with contextlib.redirect_stdout(buf):
                yield
        finally:
            wp.config.log_level = saved_level
            log.removeHandler(self)
            log.setLevel(level)
            log.propagate = propagate
            for line in buf.getvalue().splitlines():
                hit = _LOAD_LINE.match(line.strip())
                if hit and hit.group(2) == "compiled":
                    self.compile_s += float(hit.group(1)) / 1e3
                    self.n_compiled += 1
                elif hit:
                    self.load_s += float(hit.group(1)) / 1e3
                elif line.strip():
                    print(line, file=sys.stderr)


class NewtonEngine:
    """Newton's implicit MPM (``SolverImplicitMPM``) behind GASP's ``PointEngine`` contract.

    Parameters
    ----------
    setup : SimSetup
        Options already checked and completed by the core (``gasp_newton.OPTIONS``).

    Raises
    ------
    EngineError
        ``newton`` cannot be imported, or the device is absent.
    SceneError
        A point outside the domain.
    """

    def __init__(self, setup: SimSetup):
        t0 = time.perf_counter()
        self.setup, opts = setup, setup.options
        self.device = opts["device"]
        self.voxel_size = opts["voxel_size"] or setup.dx
        self.fixed_substeps = opts["n_substeps"]
        self.n_substeps = self._substeps(setup.v)
        self.substeps_seen = {self.n_substeps}
        self.frame, self.sim_time = 0, 0.0
        self.unconverged_steps, self.max_residual, self.max_iterations_used = 0, 0.0, 0
        self._check_inside(setup.x)
        init_warp(cpu_only=self.device == "cpu")
        import warp as wp
        try:
            import newton
            from newton.solvers import SolverImplicitMPM
        except ImportError as e:
            raise EngineError(f"engine 'newton': cannot import newton ({e}); pip install newton") from e
        if str(self.device).startswith("cuda") and not wp.is_cuda_available():   # before Warp prints its errors
            raise EngineError(f"engine 'newton': device {self.device!r} requested but Warp finds no CUDA device here "
                              f"(driver missing or no GPU); use device = \"cpu\"")
        try:
            self._wp_device = wp.get_device(self.device)
        except (ValueError, RuntimeError) as e:
            raise EngineError(f"engine 'newton': device {self.device!r} is not available here ({e})") from e
        self.wp = wp
        self.p_mass = setup.p_vol * np.array([m.rho for m in setup.materials])[setup.body_id]
        self._cap = _Capture()
        with self._cap.watching(), wp.ScopedDevice(self._wp_device):
            self.model = self._build_model(newton, SolverImplicitMPM)
            self.solver = SolverImplicitMPM(self.model, config=self._config(SolverImplicitMPM), verbose=True)
            self.state_0, self.state_1 = self.model.state(), self.model.state()
            if setup.C is not None:
                self.state_0.mpm.particle_qd_grad.assign(np.asarray(setup.C, dtype=np.float32))
        self.build_s = time.perf_counter() - t0

    # ------------------------------------------------------------------ build
    def _check_inside(self, x: np.ndarray) -> None:
        lo, hi = self.setup.domain_lo, self.setup.domain_hi
        out = np.flatnonzero(np.any((x < lo) | (x > hi), axis=1))
        if len(out):
            raise SceneError(f"engine 'newton': {len(out)} point(s) outside the domain [{lo.tolist()}, "
                             f"{hi.tolist()}] (first index {out[0]} at {x[out[0]].tolist()})")

    def _build_model(self, newton, solver_cls):
        s = self.setup
        b = newton.ModelBuilder(up_axis=newton.Axis.Z)
        solver_cls.register_custom_attributes(b)
        mass = self.p_mass.copy()
        mass[fixed_mask(s.x, s.boundaries)] = 0.0        # kinematic: held at its (zero) velocity
        radius = 0.5 * np.cbrt(s.p_vol)
        b.add_particles(pos=[tuple(p) for p in s.x.astype(np.float32)],
                        vel=[tuple(p) for p in s.v.astype(np.float32)],
                        mass=mass.astype(np.float32).tolist(), radius=radius.astype(np.float32).tolist())
        for bd in s.boundaries:
            cfg = newton.ModelBuilder.ShapeConfig(mu=float(bd.friction), density=0.0)
            if bd.kind == "ground":
                b.add_ground_plane(height=float(bd.height), cfg=cfg)
            elif bd.kind == "walls":
                self._add_walls(b, cfg)
        model = b.finalize(device=self._wp_device)
        model.set_gravity(tuple(float(g) for g in s.gravity))
        params = particle_parameters(s.materials, s.body_id, self.setup.options["damping"])
        for f in FIELDS:
            getattr(model.mpm, f).assign(params[f])
        return model

    def _add_walls(self, b, cfg) -> None:
        lo, hi = self.setup.domain_lo, self.setup.domain_hi
        for axis in range(3):
            for sign, at in ((1.0, lo[axis]), (-1.0, hi[axis])):
                n = [0.0, 0.0, 0.0]
                n[axis] = sign
                b.add_shape_plane(plane=(*n, -sign * float(at)), width=0.0, length=0.0, cfg=cfg)

    def _config(self, solver_cls):
        o = self.setup.options
        c = solver_cls.Config()
        c.voxel_size = float(self.voxel_size)
        c.max_iterations, c.tolerance = int(o["max_iterations"]), float(o["tolerance"])
        c.strain_basis, c.velocity_basis = o["strain_basis"], o["velocity_basis"]
        c.solver, c.transfer_scheme = o["solver"], o["transfer_scheme"]
        c.integration_scheme, c.grid_type = o["integration_scheme"], o["grid_type"]
        c.carry_residual_strain = o["carry_residual_strain"]
        c.warmstart_mode = "particles"      # the warm start lives in the state: resume is exact
        return c

    # ------------------------------------------------------------------ stepping
    def _substeps(self, v: np.ndarray) -> int:
        """Steps this frame: the ``n_substeps`` option, else the fewest with ``(v_max + |g| T) dt <= cfl voxel``.

        Newton's contact constrains only grid nodes within about a voxel of a collider, so a point that
        moves several voxels in one step passes through the ground (measured: the README donut, 1 step per
        frame, 76 points 4 cm below the ground at frame 4).
        """
        if self.fixed_substeps:
            return int(self.fixed_substeps)
        o, T = self.setup.options, self.setup.frame_dt
        speed = float(np.sqrt((np.asarray(v, dtype=np.float64) ** 2).sum(axis=1).max(initial=0.0)))
        reach = (speed + float(np.linalg.norm(self.setup.gravity)) * T) * T / (o["cfl"] * self.voxel_size)
        return int(min(o["max_substeps"], max(1, math.ceil(reach))))

    def step_frame(self) -> None:
        wp = self.wp
        self.frame += 1
        self.n_substeps = self._substeps(self.state_0.particle_qd.numpy())
        self.substeps_seen.add(self.n_substeps)
        self.dt = self.setup.frame_dt / self.n_substeps
        with self._cap.watching(), wp.ScopedDevice(self._wp_device):
            # Newton keeps the collider impulses of the last step on its grid as the next solve's warm start;
            # they are cleared at each frame boundary (particle history kept), so that the state of
            # get_state() is the whole state and a resumed run repeats bit for bit.
            self.solver.reset(self.state_0, flags=0)
            for _ in range(self.n_substeps):
                self._cap.last = None
                self.solver.step(self.state_0, self.state_1, None, None, self.dt)
                self.solver.project_outside(self.state_1, self.state_1, self.dt)
                self.state_0, self.state_1 = self.state_1, self.state_0
                self._check_solve()
        self.sim_time += self.setup.frame_dt

    def _check_solve(self) -> None:
        if self._cap.last is None:
            return
        it, l2, linf = self._cap.last
        res = max(l2, linf)
        if not math.isfinite(res):
            raise EngineDivergence(f"rheology residual {res} after {it} iterations", self.frame,
                                   CAUSE_NO_CONVERGENCE)
        self.max_residual = max(self.max_residual, res)
        self.max_iterations_used = max(self.max_iterations_used, it)
        if res >= self.setup.options["tolerance"]:
            self.unconverged_steps += 1

    def positions(self) -> np.ndarray:
        return self.state_0.particle_q.numpy().astype(np.float64)

    def velocities(self) -> np.ndarray:
        return self.state_0.particle_qd.numpy().astype(np.float64)

    def stats(self) -> dict[str, Any]:
        s = self.setup
        out = {"device": self.device, "precision": "f32", "n_points": len(s.x), "n_grid": s.n_grid,
               "voxel_size": self.voxel_size, "substeps_last": self.n_substeps,
               "substeps_range": [min(self.substeps_seen), max(self.substeps_seen)],
               "build_s": self.build_s, "compile_s": self._cap.compile_s, "kernels_compiled": self._cap.n_compiled,
               "kernel_load_s": self._cap.load_s, "unconverged_steps": self.unconverged_steps,
               "max_residual": self.max_residual, "max_iterations_used": self.max_iterations_used}
        if len(self.substeps_seen) == 1:        # the same count every frame so far: a fixed step
            out.update(n_substeps=self.n_substeps, dt=s.frame_dt / self.n_substeps)
        out.update(engine_mass_stats(self.positions(), self.p_mass))
        return out

    # ------------------------------------------------------------------ state
    def _arrays(self) -> dict[str, Any]:
        st = self.state_0
        return {"x": st.particle_q, "v": st.particle_qd, "C": st.mpm.particle_qd_grad,
                "F_e": st.mpm.particle_elastic_strain, "Jp": st.mpm.particle_Jp, "stress": st.mpm.particle_stress}

    def get_state(self) -> dict[str, np.ndarray]:
        out = {k: a.numpy().copy() for k, a in self._arrays().items()}
        out["frame"] = np.array(self.frame)
        out["sim_time"] = np.array(self.sim_time)
        return out

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        arrays = self._arrays()
        for k in (*STATE_KEYS, "frame", "sim_time"):
            if k not in state:
                raise SceneError(f"engine 'newton': saved state has no {k!r} (expected keys {list(STATE_KEYS)})")
        for k, a in arrays.items():
            v = np.asarray(state[k])
            if v.shape != a.numpy().shape:
                raise SceneError(f"engine 'newton': saved state {k!r} has shape {v.shape}, expected "
                                 f"{a.numpy().shape}")
            a.assign(v.astype(a.numpy().dtype))
        self.frame, self.sim_time = int(state["frame"]), float(state["sim_time"])

    def close(self) -> None:
        self.solver = self.model = self.state_0 = self.state_1 = None
