"""glTF binary (``.glb``) with ``KHR_gaussian_splatting``: one POINTS primitive of Gaussians, written and read
through pygltflib (the ``export`` extra).

Source: Khronos glTF extension registry, ``extensions/2.0/Khronos/KHR_gaussian_splatting/README.md``
(ratified). Attributes, all float32, one row per Gaussian:

=============================================  =====  ===============================================
attribute                                      type   GASP value
=============================================  =====  ===============================================
``POSITION``                                   VEC3   means, turned to glTF's +Y up (below)
``KHR_gaussian_splatting:ROTATION``            VEC4   unit quaternion, glTF order **x, y, z, w**
``KHR_gaussian_splatting:SCALE``               VEC3   linear scales (not logs)
``KHR_gaussian_splatting:OPACITY``             SCALAR ``sigmoid(opacity logit)`` in [0, 1]
``KHR_gaussian_splatting:SH_DEGREE_0_COEF_0``  VEC3   ``sh_dc`` (colour = 0.5 + 0.282095 ``sh_dc``)
``KHR_gaussian_splatting:SH_DEGREE_l_COEF_n``  VEC3   ``sh_rest[:, l*l - 1 + n]`` (order m = -l .. l)
``COLOR_0``                                    VEC4   the fallback point colour (linear RGB, alpha)
=============================================  =====  ===============================================

The extension object: ``kernel = "ellipse"``, ``colorSpace = "srgb_rec709_display"`` (graphdeco 3DGS trains in
display sRGB). Primitive ``mode`` 0 (POINTS).

Axes: glTF is right-handed, metres, **+Y up** (glTF 2.0 spec, "Coordinate System and Units"); GASP's world is
+Z up and a run's frames are in each object's file frame, whose up axis the scene states (``up_axis``). The
writer turns the file's up axis to +Z (:data:`UP_TO_Z`, as the scene does) and then +Z to +Y by
``(x, y, z) -> (x, z, -y)`` (a -90 degree turn about x): positions, rotations and the SH coefficients
(rotated per degree, :func:`rotate_sh`) turn together; scales, opacity and the SH DC term do not change. The
reader undoes the second step only: a GLB reads back +Z up (GASP's world convention).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.fsutil import atomic_write
from gasp_core.gs.bound import check_count
from gasp_core.gs.gaussians import Gaussians, quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.ply import SH_C0, reject_file

EXT = "KHR_gaussian_splatting"
#: Rotation taking +Z up to glTF's +Y up: ``(x, y, z) -> (x, z, -y)``.
Z_TO_Y = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
#: Rotation taking each file up axis to +Z (the scene's ``up_axis``; the same matrices as the scene's placement).
UP_TO_Z = {
    "+z": np.eye(3), "-z": np.diag([1.0, -1.0, -1.0]),
    "+y": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]), "-y": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "+x": np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]), "-x": np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
}
_FLOAT, _ARRAY_BUFFER, _POINTS = 5126, 34962, 0


def _sh_basis(d: np.ndarray, degree: int) -> np.ndarray:
    """Real SH basis of ``degree`` (1..3) at unit directions ``d`` (n, 3), shape (n, 2*degree+1), order m = -l..l,
    with the Condon-Shortley phase (the extension's Appendix A and graphdeco's ``sh_utils.py`` constants)."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    if degree == 1:
        return 0.4886025119029199 * np.stack([-y, z, -x], 1)
    if degree == 2:
        return np.stack([1.092548430592079 * x * y, -1.092548430592079 * y * z,
                         0.31539156525252 * (2 * z * z - x * x - y * y), -1.092548430592079 * x * z,
                         0.5462742152960395 * (x * x - y * y)], 1)
    return np.stack([-0.5900435899266435 * y * (3 * x * x - y * y), 2.890611442640554 * x * y * z,
                     -0.4570457994644657 * y * (4 * z * z - x * x - y * y),
                     0.3731763325901154 * z * (2 * z * z - 3 * x * x - 3 * y * y),
                     -0.4570457994644657 * x * (4 * z * z - x * x - y * y), 1.445305721320277 * z * (x * x - y * y),
                     -0.5900435899266435 * x * (x * x - 3 * y * y)], 1)


def rotate_sh(sh_rest: np.ndarray, M: np.ndarray) -> np.ndarray:
    """SH rest coefficients (n, K, 3) of Gaussians turned by the rotation ``M`` (3, 3), so that the colour seen
    along ``M d`` afterwards is the colour seen along ``d`` before.

    Per degree ``l`` the coefficients mix by ``A_l = Y_l(D)^+ Y_l(D M)`` (least squares over 64 directions ``D``;
    exact, since rotations keep each degree's span). Returns a new float32 array.
    """
    out = sh_rest.astype(np.float32, copy=True)
    D = np.random.default_rng(0).normal(size=(64, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    for l in (1, 2, 3):
        lo, hi = l * l - 1, (l + 1) * (l + 1) - 1
        if sh_rest.shape[1] < hi:
            break
        A = np.linalg.lstsq(_sh_basis(D, l), _sh_basis(D @ M, l), rcond=None)[0]   # c' = A c
        out[:, lo:hi] = np.einsum("ij,njc->nic", A, sh_rest[:, lo:hi].astype(np.float64))
    return out


def turned(g: Gaussians, M: np.ndarray) -> Gaussians:
    """``g`` turned by the rotation ``M`` (3, 3) about the origin: means, rotations and SH rest."""
    rot = rotmat_to_quat(M @ quat_to_rotmat(g.rotations))
    return Gaussians(means=g.means @ M.T, scales=g.scales, rotations=rot, opacities=g.opacities, sh_dc=g.sh_dc,
                     sh_rest=rotate_sh(g.sh_rest, M), extra={}, source=g.source, layout=g.layout, meta=g.meta)


def gltf_module(path):
    """pygltflib, or :class:`~gasp_core.errors.GaspError` naming ``path`` and the export extra's install line."""
    try:
        import pygltflib
    except ImportError:
        from gasp_core.errors import GaspError, extra_hint
        raise GaspError(f"{path}: glTF needs pygltflib, which is not installed ({extra_hint('export')})") from None
    return pygltflib


def write_glb(path, g: Gaussians, *, overwrite: bool = False, up_axis: str = "+z") -> Path:
    """Write ``g`` (file frame, up axis ``up_axis``) as a GLB with one ``KHR_gaussian_splatting`` POINTS primitive,
    atomically (module notes: attributes, axes).

    Parameters
    ----------
    path : path-like
        Destination ``.glb``; its folder must exist.
    g : Gaussians
    overwrite : bool
        Replace an existing file.
    up_axis : {"+x", "-x", "+y", "-y", "+z", "-z"}
        The file frame's up axis (the scene's ``up_axis``); it becomes glTF's +Y.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    GaspError
        pygltflib not installed.
    SceneError
        ``g`` holds no Gaussians (a glTF accessor holds at least one element).
    """
    if not g.n:
        raise SceneError(f"{path}: no Gaussians to write; a KHR_gaussian_splatting GLB holds at least one")
    b = GlbBuilder(gltf_module(path))
    mesh = b.splat_mesh(turned(g, Z_TO_Y @ UP_TO_Z[up_axis]))
    data = b.to_bytes(nodes=[{"mesh": mesh, "name": Path(g.source or "splats").stem}])
    return atomic_write(Path(path), lambda f: f.write(data), overwrite=overwrite)


def write_glb_nodes(path, parts: list[tuple[str, Gaussians]], *, overwrite: bool = False,
                    up_axis: str = "+z") -> Path:
    """As :func:`write_glb`, with one node (and its own mesh) per ``(name, Gaussians)`` of ``parts``, in that order
    (``gasp export --split-pieces``: a broken body's pieces, :mod:`gasp_core.run.split_pieces`).

    Raises
    ------
    FileExistsError, GaspError
        As :func:`write_glb`.
    """
    b = GlbBuilder(gltf_module(path))
    M = Z_TO_Y @ UP_TO_Z[up_axis]
    nodes = [{"mesh": b.splat_mesh(turned(g, M)), "name": name} for name, g in parts]
    data = b.to_bytes(nodes=nodes)
    return atomic_write(Path(path), lambda f: f.write(data), overwrite=overwrite)


class GlbBuilder:
    """Accumulates float32 accessors, splat meshes and nodes into one GLB (one buffer, the binary chunk).

    Parameters
    ----------
    gl : module
        pygltflib (:func:`gltf_module`).
    """

    def __init__(self, gl):
        self.gl, self.blob, self.views, self.accessors, self.meshes = gl, bytearray(), [], [], []

    def array(self, a, bounds: bool = False, vertex: bool = True) -> int:
        """Add ``a`` (n,) or (n, k) as a float32 accessor (``bounds``: with min/max, as ``POSITION`` needs);
        its index."""
        gl, a = self.gl, np.ascontiguousarray(a, np.float32)
        self.views.append(gl.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=a.nbytes,
                                        target=_ARRAY_BUFFER if vertex else None))
        acc = gl.Accessor(bufferView=len(self.views) - 1, componentType=_FLOAT, count=len(a),
                          type={1: "SCALAR", 3: "VEC3", 4: "VEC4"}[1 if a.ndim == 1 else a.shape[1]])
        if bounds:
            acc.min, acc.max = np.atleast_1d(a.min(0)).tolist(), np.atleast_1d(a.max(0)).tolist()
        self.accessors.append(acc)
        self.blob += a.tobytes()
        return len(self.accessors) - 1

    def splat_mesh(self, t: Gaussians) -> int:
        """Add a mesh of one ``KHR_gaussian_splatting`` POINTS primitive holding ``t`` (already in glTF axes);
        its index (module notes: the attributes)."""
        alpha = 1.0 / (1.0 + np.exp(-t.opacities.astype(np.float64)))
        colour = np.clip(0.5 + SH_C0 * t.sh_dc.astype(np.float64), 0.0, 1.0)
        linear = np.where(colour <= 0.04045, colour / 12.92, ((colour + 0.055) / 1.055) ** 2.4)   # COLOR_0 is linear
        cols = {"POSITION": t.means, f"{EXT}:ROTATION": t.rotations[:, [1, 2, 3, 0]], f"{EXT}:SCALE": t.scales,
                f"{EXT}:OPACITY": alpha, f"{EXT}:SH_DEGREE_0_COEF_0": t.sh_dc,
                "COLOR_0": np.concatenate([linear, alpha[:, None]], 1)}
        for l in (1, 2, 3):
            for n in range(2 * l + 1):
                if l * l - 1 + n < t.sh_rest.shape[1]:
                    cols[f"{EXT}:SH_DEGREE_{l}_COEF_{n}"] = t.sh_rest[:, l * l - 1 + n]
        attributes = {name: self.array(a, bounds=name == "POSITION") for name, a in cols.items()}
        prim = self.gl.Primitive(attributes=self.gl.Attributes(POSITION=0), mode=_POINTS,
                                 extensions={EXT: {"kernel": "ellipse", "colorSpace": "srgb_rec709_display"}})
        prim.attributes = attributes   # the extension's semantics are not Python names: a plain dict serialises them
        self.meshes.append(self.gl.Mesh(primitives=[prim]))
        return len(self.meshes) - 1

    def to_bytes(self, nodes: list[dict], animations: list | None = None, used: tuple[str, ...] = (),
                 required: tuple[str, ...] = ()) -> bytes:
        """The GLB: ``nodes`` (dicts of glTF node properties: ``mesh``, ``name``, ``extensions``) all in the scene,
        ``animations`` (pygltflib ``Animation``), the extensions ``used`` and ``required`` besides this one."""
        gl = self.gl
        doc = gl.GLTF2(asset=gl.Asset(generator="GASP", version="2.0"), scene=0,
                       scenes=[gl.Scene(nodes=list(range(len(nodes))))], nodes=[gl.Node(**n) for n in nodes],
                       meshes=self.meshes, accessors=self.accessors, bufferViews=self.views,
                       buffers=[gl.Buffer(byteLength=len(self.blob))], extensionsUsed=[EXT, *used],
                       animations=animations or [])
        if required:
            doc.extensionsRequired = list(required)
        doc.set_binary_blob(bytes(self.blob))
        return b"".join(doc.save_to_bytes())


def read_glb(path, fmt: str = "glb") -> Gaussians:
    """Read the first ``KHR_gaussian_splatting`` primitive of a GLB (float32 attributes, as :func:`write_glb` and
    splat-transform write them), turned back from +Y up to +Z up (module notes); the node transform is ignored.

    Returns
    -------
    Gaussians
        Means float64, linear scales, unit wxyz rotations, opacity logits (``logit(OPACITY)``), SH as stored
        (rotated back). ``layout = "glb"``.

    Raises
    ------
    SceneError
        No splat primitive, a missing required attribute, an attribute that is not float32, or rows that do not
        match (one line naming the file).
    GaspError
        pygltflib not installed.
    """
    gl = gltf_module(path)
    # 56 bytes a splat at least (float32 POSITION, ROTATION, SCALE, OPACITY, SH 0): bounded before it is read
    check_count(path, Path(path).stat().st_size // 56, "its size")
    try:
        doc = gl.GLTF2().load_binary(str(path))
        blob = doc.binary_blob()
    except Exception as e:   # pygltflib raises several kinds for a corrupt file
        reject_file(path, f"not a readable GLB file (truncated or corrupt?): {type(e).__name__}: {e}")
    prims = [p for m in (doc.meshes or []) for p in (m.primitives or []) if EXT in (p.extensions or {})]
    if not prims:
        reject_file(path, f"no primitive with {EXT}; expected a Gaussian Splatting glTF")
    attrs = prims[0].attributes
    if attrs is None or not (isinstance(attrs, dict) or hasattr(attrs, "__dict__")):
        reject_file(path, f"the {EXT} primitive's attributes are {attrs!r}; expected a table of accessors")
    attrs = attrs if isinstance(attrs, dict) else {k: v for k, v in vars(attrs).items() if v is not None}

    def column(name, width, required=True):
        if name not in attrs:
            if required:
                reject_file(path, f"attribute {name} missing; expected the {EXT} attributes")
            return None
        acc = doc.accessors[attrs[name]]
        view = doc.bufferViews[acc.bufferView]
        if acc.componentType != _FLOAT:
            reject_file(path, f"attribute {name}: component type {acc.componentType}; GASP reads float32 (5126)")
        stride, off = view.byteStride or 4 * width, (view.byteOffset or 0) + (acc.byteOffset or 0)
        if acc.count < 1 or off + (acc.count - 1) * stride + 4 * width > len(blob):
            reject_file(path, f"attribute {name}: {acc.count} rows do not fit the binary chunk (truncated?)")
        return np.ndarray((acc.count, width), np.float32, buffer=blob, offset=off, strides=(stride, 4)).astype(np.float64)

    try:
        means = column("POSITION", 3)
        rot = column(f"{EXT}:ROTATION", 4)[:, [3, 0, 1, 2]]
        scales = column(f"{EXT}:SCALE", 3)
        alpha = np.clip(column(f"{EXT}:OPACITY", 1)[:, 0], 1e-12, 1 - 1e-7)
        sh_dc = column(f"{EXT}:SH_DEGREE_0_COEF_0", 3)
        rest = [c for l in (1, 2, 3) for n in range(2 * l + 1)
                if (c := column(f"{EXT}:SH_DEGREE_{l}_COEF_{n}", 3, required=False)) is not None]
    except SceneError:
        raise
    except (IndexError, TypeError, KeyError, ValueError, AttributeError) as e:   # accessors or views that do not exist
        reject_file(path, f"{EXT} accessors that do not resolve (corrupt?): {type(e).__name__}: {e}")
    if len({len(means), len(rot), len(scales), len(alpha), len(sh_dc)}) != 1 or len(rest) not in (0, 3, 8, 15):
        reject_file(path, f"{EXT} attributes of different lengths, or {len(rest)} SH rest coefficients; expected "
                    "one row per splat and 0, 3, 8 or 15 coefficients")
    norm = np.linalg.norm(rot, axis=1, keepdims=True)
    if not (np.isfinite(norm) & (norm > 1e-12)).all():   # before dividing by it
        reject_file(path, "zero or non-finite rotation quaternion")
    n = len(means)
    sh_rest = np.stack(rest, 1).astype(np.float32) if rest else np.zeros((n, 0, 3), np.float32)
    g = Gaussians(means=means, scales=scales, rotations=rot / norm,
                  opacities=np.log(alpha / (1 - alpha)).astype(np.float32), sh_dc=sh_dc.astype(np.float32),
                  sh_rest=sh_rest, source=str(path), layout="glb")
    from gasp_core.gs.formats import check_decoded   # the checks every reader that is not PLY's makes
    return turned(check_decoded(path, g), Z_TO_Y.T)
