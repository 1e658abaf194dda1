"""The format registry (issue 42 item 4): one record per format, every reader and writer reached through it,
``docs/formats.md``'s tables generated from it."""
import re

import numpy as np
import pytest
from formats_testing import write_ksplat, write_splat
from gasp_testing import ROOT

from gasp_core.errors import GaspError, SceneError
from gasp_core.gs import registry
from gasp_core.gs.io import read_gaussians

DATA = ROOT / "examples" / "data"


def _glb(tmp_path, g):
    pytest.importorskip("pygltflib", reason="the export extra is not installed")
    from gasp_core.gs.gltf import write_glb
    return write_glb(tmp_path / "x.glb", g)


#: A file of every readable format and its Gaussian count: (format name -> maker(tmp_path, 1000-splat source)).
SAMPLES = {
    "ply": lambda tmp, g: DATA / "train-1000.ply",
    "compressed_ply": lambda tmp, g: DATA / "guitar.compressed.ply",
    "spz": lambda tmp, g: DATA / "train-1000.spz",
    "sog": lambda tmp, g: DATA / "train-1000.sog",
    "splat": lambda tmp, g: (write_splat(tmp / "x.splat", g), tmp / "x.splat")[1],
    "ksplat": lambda tmp, g: (write_ksplat(tmp / "x.ksplat", g), tmp / "x.ksplat")[1],
    "splatv": lambda tmp, g: DATA / "spinach_4.splatv",
    "glb": _glb,
}
COUNTS = {"compressed_ply": 90854, "splatv": 62442}


def test_the_samples_cover_every_readable_format():
    assert set(SAMPLES) == set(registry.readable())


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_a_file_of_every_readable_format_goes_through_the_registry(name, tmp_path):
    if name in ("spz", "sog"):
        pytest.importorskip("gsply", reason="the formats extra is not installed")
    src = read_gaussians(DATA / "train-1000.ply")
    path = SAMPLES[name](tmp_path, src)
    assert registry.sniff(path).name == name
    g = read_gaussians(path)
    assert g.n == COUNTS.get(name, 1000)
    assert np.isfinite(g.means).all() and (g.scales >= 0).all()
    if name in ("ply", "splat", "ksplat"):   # same Gaussians, any order: the bounding box within 1e-3 of the extent
        ext = np.ptp(src.means, axis=0).max()
        np.testing.assert_allclose(g.means.min(0), src.means.min(0), atol=1e-3 * ext)
        np.testing.assert_allclose(g.means.max(0), src.means.max(0), atol=1e-3 * ext)


def test_docs_formats_md_holds_the_registry_tables():
    text = (ROOT / "docs" / "formats.md").read_text()
    m = re.search(r"<!-- registry tables: begin[^\n]*-->\n(.*?)<!-- registry tables: end -->", text, re.S)
    assert m, "docs/formats.md lost its generated block"
    assert m.group(1) == registry.markdown_tables(), \
        "docs/formats.md differs from the registry: paste the output of python -m gasp_core.gs.registry"
    for name in registry.FORMATS:
        assert f"`{name}`" in m.group(1)


def test_cli_choices_and_help_come_from_the_registry(capsys):
    from gasp_core.cli.main import build_parser
    from gasp_core.run.request import FORMATS
    assert FORMATS == registry.output_formats() and {"glb", "usd"} <= set(FORMATS)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["info", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    for name in registry.readable():
        assert registry.FORMATS[name].title.split(":")[0] in out


def test_a_mesh_glb_and_a_usd_file_are_refused_in_one_line(tmp_path):
    import struct
    doc = b'{"asset":{"version":"2.0"}}  '
    (tmp_path / "mesh.glb").write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(doc)) +
                                        struct.pack("<II", len(doc), 0x4E4F534A) + doc)
    with pytest.raises(SceneError, match="triangle mesh .*mesh mode"):
        registry.sniff(tmp_path / "mesh.glb")
    (tmp_path / "a.usdc").write_bytes(b"PXR-USDC" + b"\0" * 80)
    with pytest.raises(SceneError, match="OpenUSD file: GASP writes USD"):
        read_gaussians(tmp_path / "a.usdc")
    (tmp_path / "a.xyz").write_bytes(b"\0" * 16)
    with pytest.raises(SceneError, match=r"unknown file format .*expected a PLY, .spz, .sog, .splat, .ksplat, .splatv, "
                                         r".glb file"):
        registry.sniff(tmp_path / "a.xyz")


def test_writers_refuse_reading_only_formats_and_missing_libraries(monkeypatch):
    with pytest.raises(GaspError, match="--format splat: GASP reads .splat files but does not write them"):
        registry.check_writer("splat")
    with pytest.raises(GaspError, match="unknown format 'obj'"):
        registry.get("obj")
    import builtins
    real = builtins.__import__
    monkeypatch.setattr(builtins, "__import__", lambda name, *a, **k: (_ for _ in ()).throw(ImportError(name))
                        if name == "pygltflib" else real(name, *a, **k))
    with pytest.raises(GaspError, match=r"--format glb needs pygltflib, which is not installed .*\[export\]"):
        registry.check_writer("glb")


def _glb_bytes(doc: dict, blob: bytes) -> bytes:
    import json
    import struct
    j = json.dumps(doc).encode()
    j += b" " * ((4 - len(j) % 4) % 4)
    blob += b"\0" * ((4 - len(blob) % 4) % 4)
    return (b"glTF" + struct.pack("<II", 2, 28 + len(j) + len(blob)) + struct.pack("<II", len(j), 0x4E4F534A) + j
            + struct.pack("<II", len(blob), 0x004E4942) + blob)


@pytest.mark.parametrize("damage", ["view", "count", "type", "missing", "truncated"])
def test_a_damaged_glb_is_refused_in_one_line(damage, tmp_path):
    import json
    import struct
    pytest.importorskip("pygltflib", reason="the export extra is not installed")
    from gasp_core.gs.gltf import write_glb
    g = read_gaussians(DATA / "train-1000.ply").subset(np.arange(10))
    raw = write_glb(tmp_path / "ok.glb", g).read_bytes()
    n = struct.unpack_from("<I", raw, 12)[0]
    doc, blob = json.loads(raw[20:20 + n]), raw[28 + n:]
    attrs = doc["meshes"][0]["primitives"][0]["attributes"]
    if damage == "view":
        doc["accessors"][0]["bufferView"] = 99
    elif damage == "count":
        doc["accessors"][0]["count"] = 10 ** 9
    elif damage == "type":
        doc["accessors"][attrs["KHR_gaussian_splatting:ROTATION"]]["componentType"] = 5121
    elif damage == "missing":
        del attrs["KHR_gaussian_splatting:SCALE"]
    else:
        blob = blob[:100]
    (tmp_path / "bad.glb").write_bytes(_glb_bytes(doc, blob))
    with pytest.raises(SceneError) as e:
        read_gaussians(tmp_path / "bad.glb")
    line = str(e.value)
    assert line.startswith(f"{tmp_path / 'bad.glb'}: ") and "\n" not in line and line.count("bad.glb") == 1, line


def test_reading_needs_only_the_readers_libraries(monkeypatch):
    """A compressed PLY reads without gsply (GASP decodes it), though writing one needs gsply."""
    import builtins
    real = builtins.__import__
    monkeypatch.setattr(builtins, "__import__", lambda name, *a, **k: (_ for _ in ()).throw(ImportError(name))
                        if name.split(".")[0] == "gsply" else real(name, *a, **k))
    assert read_gaussians(DATA / "guitar.compressed.ply").n == 90854
    with pytest.raises(GaspError, match="--format compressed_ply needs gsply"):
        registry.check_writer("compressed_ply")
