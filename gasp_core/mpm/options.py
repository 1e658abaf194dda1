"""The settings of a grid (MPM) engine as typed records (issue 51 item 2, :mod:`gasp_core.seam.config`).

- :class:`GridConfig`: what every grid engine takes (``device``, ``precision``, ``dt``, ``n_substeps``, ``cfl``,
  ``max_substeps``); ``dt`` excludes ``n_substeps`` as declared data (the core checks them).
- :class:`MPMConfig`: the MLS-MPM engines of ``docs/mpm.md`` add ``passive_every``, ``flip``, ``transfer_damping``,
  ``contact``, ``contact_balance``, ``contact_fields`` and ``stress_at`` (round 68), and declare the quality levels' presets measured on them (``docs/speed_accuracy.md``).

A plugin subclasses one of them with its own fields (a thread count, say) and registers it with
``EngineInfo(config=...)``; the engine reads ``config(**setup.options)``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gasp_core.seam.config import Preset, config_options, from_option, option
from gasp_core.seam.options import Option
from gasp_core.mpm.contact import BALANCE, CONTACT
from gasp_core.mpm.fields import FIELDS
from gasp_core.mpm.cells import CELLS
from gasp_core.mpm.stress_at import STRESS_AT, STRESS_PASSES
from gasp_core.mpm.substeps import CFL, CFL_RULE, CFL_RULES, MAX_SUBSTEPS, PASSIVE_EVERY
from gasp_core.mpm.transfer import FLIP, TRANSFER_DAMPING


@dataclass(frozen=True)
class GridConfig:
    """Every grid engine's settings (``docs/mpm.md``). ``device`` is ``"cpu"`` or ``"cuda"`` (the default GPU)."""

    device: str = option("cpu", "where to run: 'cpu' or 'cuda' (the default GPU)", kind="str", choices=("cpu", "cuda"))
    precision: str = option("f32", "floating-point precision of the solver", kind="str", choices=("f32", "f64"))
    dt: float | None = option(None, "substep length, s (default: from cfl); not with n_substeps", kind="number",
                              lo=0.0, lo_open=True, excludes=("n_substeps",))
    n_substeps: int | None = option(None, "substeps per frame (default: from cfl); not with dt", kind="int", lo=1)
    cfl: float = option(CFL, "Courant number of the automatic substep: dt = cfl dx / (c_p + v_max) (cfl_rule)",
                        kind="number", lo=0.0, hi=1.0, lo_open=True)
    cfl_rule: str = option(CFL_RULE, "the speed of the automatic substep: 'sum' (the default since round 54), "
                           "dt = cfl dx / (c_p + v_max), the wave and the material speed together; 'max', "
                           "cfl dx / max(c_p, v_max) (the jelly donut thrown at 4.43 m/s at cfl 0.8: its elastic "
                           "step's gain 8.7 % with 'max', 2.75 % with 'sum' at 1.63x the substeps; docs/fracture.md, "
                           "rounds 53-54)",
                           kind="str", choices=CFL_RULES)
    max_substeps: int = option(MAX_SUBSTEPS, "refuse a scene needing more substeps per frame than this "
                               "(bounds the work a bad value can ask for)", kind="int", lo=1)


#: ``device`` of an engine that can run on a chosen GPU ("cuda:N").
CUDA_INDEX_DEVICE = dict(default="cpu", doc="where to run: 'cpu', 'cuda' (the default GPU) or 'cuda:N' (GPU N)",
                         kind="str", pattern=r"cpu|cuda(:\d+)?")


@dataclass(frozen=True)
class GridConfigCudaIndex(GridConfig):
    """:class:`GridConfig` for an engine that can run on a chosen GPU: ``device`` also takes ``"cuda:N"``."""

    device: str = option(**CUDA_INDEX_DEVICE)


#: The quality levels' engine options, measured on the MLS-MPM engines (docs/speed_accuracy.md, "Quality levels"):
#: ``draft`` gathers at passive points every 16th substep, ``default`` every 8th, both at ``cfl`` 0.8;
#: ``reference`` steps at ``cfl`` 0.2.
MPM_PRESETS = {
    "draft": Preset({"passive_every": 16, "cfl": 0.8}, measured="docs/speed_accuracy.md"),
    "default": Preset({"passive_every": 8, "cfl": 0.8}, measured="docs/speed_accuracy.md"),
    "reference": Preset({"cfl": 0.2}, measured="docs/speed_accuracy.md"),
}


@dataclass(frozen=True)
class MPMConfig(GridConfig):
    """The MLS-MPM engines' settings (``docs/mpm.md``): :class:`GridConfig` and the passive points' schedule, the
    AFLIP blend, the contact model, its balance and the two-field contact of flowing bodies, with the quality levels of
    :data:`MPM_PRESETS`."""

    passive_every: int = from_option(PASSIVE_EVERY)
    flip: float = from_option(FLIP)
    transfer_damping: str = from_option(TRANSFER_DAMPING)
    contact: str = from_option(CONTACT)
    contact_balance: bool = from_option(BALANCE)
    contact_fields: bool = from_option(FIELDS)
    stress_at: str = from_option(STRESS_AT)
    stress_passes: int = from_option(STRESS_PASSES)
    fracture_cells: bool = from_option(CELLS)
    PRESETS: ClassVar = MPM_PRESETS


@dataclass(frozen=True)
class MPMConfigCudaIndex(MPMConfig):
    """:class:`MPMConfig` for an engine that can run on a chosen GPU: ``device`` also takes ``"cuda:N"``."""

    device: str = option(**CUDA_INDEX_DEVICE)


def mpm_options(*extra: Option, cuda_index: bool = False) -> tuple[Option, ...]:
    """The options of :class:`GridConfig` (or :class:`GridConfigCudaIndex`), then ``extra``: for an engine that
    declares its options as a tuple rather than a config class.

    Returns
    -------
    tuple of Option
        For :attr:`gasp_core.seam.engine.EngineInfo.options`.
    """
    return config_options(GridConfigCudaIndex if cuda_index else GridConfig) + tuple(extra)


#: The options every MPM engine of this project takes (``docs/mpm.md``), ``device`` "cpu" or "cuda".
MPM_OPTIONS = mpm_options()
