"""The declared options of a grid (MPM) engine; ``dt`` excludes ``n_substeps`` as declared data (the core checks them)."""
from __future__ import annotations

from gasp_core.seam.options import Option
from gasp_core.toolkit.substeps import CFL, MAX_SUBSTEPS


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
        Option("cfl", CFL, "Courant number of the automatic substep: dt = cfl dx / max(c_p, v_max)",
               kind="number", lo=0.0, hi=1.0, lo_open=True),
        Option("max_substeps", MAX_SUBSTEPS, "refuse a scene needing more substeps per frame than this "
               "(bounds the work a bad value can ask for)", kind="int", lo=1),
    ) + tuple(extra)


#: The options every MPM engine of this project takes (``docs/mpm.md``), ``device`` "cpu" or "cuda".
MPM_OPTIONS = mpm_options()
