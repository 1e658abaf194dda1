"""A ``.blend`` writer for ``gasp export-soup`` (``gasp_soup_writers`` hook of :mod:`gasp_blender`, format ``blend``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.seam import EngineError

from . import bpy_available


def write_blend(outdir: Path, soups: dict[str, np.ndarray]) -> list[str]:
    """Write ``soup.blend``: one mesh object per scene object, vertex ``3 i + k`` = corner k of face i.

    Parameters
    ----------
    outdir : Path
        Existing folder.
    soups : dict of str -> ndarray, shape (n, 3, 3)
        Rest triangles per object, world frame, metres.

    Returns
    -------
    list of str
        ``["soup.blend"]``.

    Raises
    ------
    EngineError
        bpy is not installed.
    """
    reason = bpy_available()
    if reason:
        raise EngineError(reason)
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for name, tri in soups.items():
        tri = np.asarray(tri, dtype=np.float64)
        me = bpy.data.meshes.new(name)
        n = len(tri)
        me.vertices.add(3 * n)
        me.vertices.foreach_set("co", tri.reshape(-1).astype(np.float32))
        me.loops.add(3 * n)
        me.loops.foreach_set("vertex_index", np.arange(3 * n, dtype=np.int32))
        me.polygons.add(n)
        me.polygons.foreach_set("loop_start", np.arange(0, 3 * n, 3, dtype=np.int32))
        me.update(calc_edges=True)
        obj = bpy.data.objects.new(name, me)
        bpy.context.scene.collection.objects.link(obj)
    path = Path(outdir) / "soup.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path.resolve()), check_existing=False, compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return [path.name]
