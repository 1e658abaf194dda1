"""One compile per install (issue 54 item 7): every kernel of this plugin, for a scalar type and a device, compiled into
Warp's kernel cache on the first run, so that a later scene, whatever its sizes and features, compiles nothing.

Every kernel of the plugin is built by a ``build_*(Ft)`` function of one of its files, a closure over the scalar type
alone (``tests/test_warp_warmup.py`` checks that no kernel is defined elsewhere); the points and the grid are kernel
arguments, so a kernel's machine code does not depend on the scene. Warp compiles a module when a launch first needs
it and keeps it in its kernel cache (https://nvidia.github.io/warp/configuration.html, ``kernel_cache_dir``), so
without this a scene that uses a feature the scenes before it did not (a collider of the rest of a capture, a rigid
body, a viscous material) compiled its modules then. :func:`compile_all` builds them all at once, loaded by
:func:`warp.force_load` one after another (Warp's default; in worker threads it was slower on 2 cores,
docs/performance.md "Warp on CPU uses one core"), and leaves a marker in the cache folder
named by a digest of the plugin's source, Warp's version, the scalar type and the device, so that the next run skips
it; clearing Warp's cache (``wp.clear_kernel_cache()``) removes the marker with the modules.
"""
import hashlib
import importlib
import pkgutil
import types
import warnings
from pathlib import Path

import warp as wp

from gasp_core.fsutil import atomic_write

from .precision import MODULE_OPTIONS

PACKAGE = __name__.rpartition(".")[0]


def _kernels_in(obj, seen: set) -> list:
    """The Warp kernels in a builder's result: the result itself, the items of a tuple, list or dict, the attributes
    of a namespace, and the kernels a returned function closes over."""
    if id(obj) in seen:
        return []
    seen.add(id(obj))
    if isinstance(obj, wp.Kernel):
        return [obj]
    if isinstance(obj, dict):
        items = list(obj.values())
    elif isinstance(obj, (tuple, list)):
        items = list(obj)
    elif isinstance(obj, types.SimpleNamespace):
        items = list(vars(obj).values())
    elif isinstance(obj, types.FunctionType) and obj.__closure__:
        items = [c.cell_contents for c in obj.__closure__ if c.cell_contents is not None]
    else:
        return []
    return [k for item in items for k in _kernels_in(item, seen)]


def plugin_modules() -> list:
    """Every Python module of this plugin, imported (``pkgutil.walk_packages`` over the package's folder: its
    subpackages' modules too, ``schedule.gpu``)."""
    pkg = importlib.import_module(PACKAGE)
    return [importlib.import_module(m.name) for m in pkgutil.walk_packages(pkg.__path__, prefix=f"{PACKAGE}.")]


def all_kernels(Ft) -> list:
    """Every Warp kernel of the plugin for scalar type ``Ft`` (``wp.float32`` or ``wp.float64``): the results of every
    ``build_*`` function defined in one of its modules, called with ``Ft`` (each is cached per type, so the engine
    later gets the same kernels). Returns a list of :class:`warp.Kernel`, each once."""
    seen, kernels = set(), []     # seen: what _kernels_in has visited, so each kernel comes once
    for mod in plugin_modules():
        for name, fn in sorted(vars(mod).items()):
            if name.startswith("build_") and callable(fn) and getattr(fn, "__module__", None) == mod.__name__:
                kernels += _kernels_in(fn(Ft), seen)
    return kernels


def _sources() -> list:
    """(name, path) of the plugin's ``.py`` files: those beside this module, then its subpackages' (``schedule/``,
    found where that package was imported from)."""
    from . import schedule
    files = [(f.name, f) for f in sorted(Path(__file__).parent.glob("*.py"))]
    sub = Path(schedule.__file__).parent
    return files + [(f"{sub.name}/{f.name}", f) for f in sorted(sub.glob("*.py"))]


def marker_path(Ft, device) -> Path:
    """The marker :func:`compile_all` leaves in Warp's kernel cache folder once every kernel of ``Ft`` is compiled for
    ``device``: named by a digest of the plugin's ``.py`` files (:func:`_sources`), Warp's version, the module
    options, the scalar type and the device (its name and, on CUDA, its architecture)."""
    h = hashlib.sha256()
    for name, f in _sources():
        h.update(name.encode() + b"\0" + f.read_bytes())
    dev = wp.get_device(device)
    h.update(f"{wp.config.version}|{sorted(MODULE_OPTIONS.items())}|{Ft.__name__}|{dev.name}|"
             f"{getattr(dev, 'arch', '')}".encode())
    return Path(wp.config.kernel_cache_dir) / f"gasp_warp_mpm-{h.hexdigest()[:20]}.compiled"


def compile_all(Ft, device) -> bool:
    """Every kernel of the plugin for scalar type ``Ft`` compiled (or loaded from Warp's cache) on ``device``, once per
    install: skipped where the marker (:func:`marker_path`) is there. Call after ``wp.init()``.

    Returns True where it compiled, False where the marker said it was done. Raises what Warp raises for a kernel
    that does not compile."""
    marker = marker_path(Ft, device)
    if marker.exists():
        return False
    modules = list({k.module.name: k.module for k in all_kernels(Ft)}.values())
    wp.force_load(device=device, modules=modules)   # one after another (Warp's default): see the module's notes
    try:
        atomic_write(marker, lambda f: f.write(f"{len(modules)} modules of {PACKAGE} for {Ft.__name__} on {device}\n"),
                     binary=False)
    except OSError as e:     # a read-only or full cache whose kernels loaded: the run runs (issue 68), said once
        if marker.parent not in _UNWRITABLE:
            _UNWRITABLE.add(marker.parent)
            warnings.warn(f"warp_mpm: Warp's kernel cache {marker.parent} cannot be written ({e.strerror or e}): "
                          "every kernel loaded, but the next run checks them all again; make the folder writable "
                          "or set WARP_CACHE_PATH to one that is", stacklevel=2)
    return True


#: Cache folders whose marker could not be written, said once each (:func:`compile_all`).
_UNWRITABLE: set = set()
