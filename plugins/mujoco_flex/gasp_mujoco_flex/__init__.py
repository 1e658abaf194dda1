"""GASP engine plugin ``mujoco_flex``: MuJoCo 4 flex bodies carrying the scene's points.

Each deformable body becomes a coarse conforming tetrahedral lattice (a ``flexcomp`` of type
``direct``, 3D, with MuJoCo's Saint Venant-Kirchhoff flex elasticity); every input point rides
on its lattice tetrahedron through fixed barycentric weights. Rigid bodies become MuJoCo free
bodies made of one box per occupied lattice cell.

Importing this module does not import ``mujoco``; the factory does.
"""
from __future__ import annotations

import importlib.util

from gasp_core.engine import Capabilities, EngineInfo
from gasp_core.plugins import hookimpl

__all__ = ["gasp_engines", "make_engine", "CAPABILITIES"]

#: What the engine offers. ``metal`` is MuJoCo's flex von Mises plasticity (elasticity ``yield``).
CAPABILITIES = Capabilities(
    materials=frozenset({"jelly", "metal", "rigid"}),
    boundaries=frozenset({"ground", "fixed_region"}),
    devices=frozenset({"cpu"}),
    precisions=frozenset({"f64"}),
    dims=frozenset({3}),
    deterministic=frozenset({"cpu"}),
    grid_based=False,
)


def _available() -> str | None:
    if importlib.util.find_spec("mujoco") is None:
        return "the 'mujoco' package is not installed (pip install 'mujoco>=4')"
    return None


def make_engine(setup):
    """Build a :class:`~gasp_mujoco_flex.engine.MujocoFlexEngine` from a ``SimSetup`` (imports mujoco)."""
    from .engine import MujocoFlexEngine
    return MujocoFlexEngine(setup)


@hookimpl
def gasp_engines():
    """The ``mujoco_flex`` engine record."""
    return [EngineInfo(
        name="mujoco_flex",
        factory=make_engine,
        capabilities=CAPABILITIES,
        available=_available,
        description="MuJoCo 4 flex: tetrahedral FEM lattice per body (SVK elasticity, von Mises "
                    "plasticity), points embedded barycentrically; rigid bodies as free bodies",
    )]
