"""Issue 34: the hostile corpus's cases that main got wrong, each as the user met it.

Data loss first (``--overwrite`` deletes only what a run wrote), then work bounded before it is
spent, then the silently wrong cases, then tracebacks that must be one ``gasp: error:`` line.
Every case takes seconds.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.cli.main import main
from gasp_core.errors import GaspError
from gasp_core.fsutil import CLAIM, OutputClaim, atomic_json


def finished_run(claim: OutputClaim, objects=("small",)) -> None:
    """What a finished run writes into its partial folder, committed."""
    tmp = claim.partial_dir()
    for name in objects:
        (tmp / name).mkdir()
        (tmp / name / "frame_0000.ply").write_bytes(b"ply")
    atomic_json(tmp / "frames.json", {"objects": [{"name": n} for n in objects]})
    atomic_json(tmp / "run.json", {"objects": [{"name": n} for n in objects]})
    claim.commit(tmp)


def one_error(err: str, code: int, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------------------------ 1. data loss


@pytest.mark.parametrize("added", ["small/notes.txt", "small/edits/notes.txt", ".gasp-notes", "notes.txt"])
def test_a_file_added_inside_a_run_folder_survives_overwrite(tmp_path, added):
    out = tmp_path / "out"
    finished_run(OutputClaim(out))
    (out / added).parent.mkdir(parents=True, exist_ok=True)
    (out / added).write_text("x")
    with pytest.raises(GaspError, match="did not write") as e:
        OutputClaim(out, overwrite=True)
    assert added.split("/")[-1] in str(e.value) or added.split("/")[0] in str(e.value)
    assert (out / added).read_text() == "x" and not (out / CLAIM).exists()


def test_an_edited_frame_survives_overwrite(tmp_path):
    out = tmp_path / "out"
    finished_run(OutputClaim(out))
    (out / "run.json").write_text('{"my": "notes, same file, edited"}')
    with pytest.raises(GaspError, match=r"run.json \(changed\)"):
        OutputClaim(out, overwrite=True)
    assert "my" in (out / "run.json").read_text()


@pytest.mark.parametrize("beside", [False, True])
def test_a_users_folder_holding_a_run_json_is_not_a_run(tmp_path, beside):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "run.json").write_text('{"objects": [{"name": "small"}]}')
    if beside:
        (mine / "small").mkdir()
        (mine / "small" / "thesis.tex").write_text("x")
    with pytest.raises(GaspError, match="not a gasp output"):
        OutputClaim(mine, overwrite=True)
    assert (mine / "run.json").exists() and (not beside or (mine / "small" / "thesis.tex").exists())


def test_overwrite_still_replaces_an_untouched_run(tmp_path):
    out = tmp_path / "out"
    finished_run(OutputClaim(out), objects=("old",))
    finished_run(OutputClaim(out, overwrite=True), objects=("new",))
    assert sorted(p.name for p in out.iterdir()) == [".gasp-output", "frames.json", "new", "run.json"]
    assert not [p for p in tmp_path.iterdir() if p.name != "out"]


def test_simulate_overwrite_keeps_a_note_in_the_object_folder(tmp_path, donut_small, capsys):
    """The issue's repro through the command: simulate, add a note, simulate --overwrite."""
    needs_package("gasp_warp_mpm")
    from gasp_testing import scene_text
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm", engine_options="{ }"))
    out = tmp_path / "out"
    assert main(["simulate", str(scene), "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    (out / "donut_small" / "notes.txt").write_text("x")
    code = main(["simulate", str(scene), "-o", str(out), "-q", "--overwrite"])
    line = one_error(capsys.readouterr().err, code)
    assert "donut_small/notes.txt" in line
    assert (out / "donut_small" / "notes.txt").read_text() == "x"
    assert (out / "donut_small" / "frame_0001.ply").exists()


# ------------------------------------------------------------------ render and view: values checked first


@pytest.fixture
def mini_run(tmp_path, donut_small):
    """A run folder as gasp simulate writes it (PLY frames, frames.json, run.json), from the real donut."""
    from gasp_core.gs.io import read_gaussians, write_gaussians
    run = tmp_path / "run"
    (run / "obj").mkdir(parents=True)
    g = read_gaussians(donut_small)
    for f in range(2):
        write_gaussians(run / "obj" / f"frame_{f:04d}.ply", g)
    atomic_json(run / "frames.json", {"format": "ply", "layout": "frames", "n_frames": 2, "objects": [
        {"name": "obj", "n_gaussians": g.n, "frames": ["obj/frame_0000.ply", "obj/frame_0001.ply"]}]})
    atomic_json(run / "run.json", {"engine": "test", "frame_dt": 0.04, "objects": [
        {"name": "obj", "placement": {"R": np.eye(3).tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]})
    return run


RENDER_CASES = {
    "fov-0": (["--fov", "0"], "--fov"),
    "fov-180": (["--fov", "180"], "--fov"),
    "fov-nan": (["--fov", "nan"], "--fov"),
    "camera-nan": (["--camera", "nan,nan,nan"], "--camera"),
    "camera-at-look-at": (["--camera", "0,0,1", "--look-at", "0,0,1"], "same point"),
    "orbit-nan": (["--orbit", "nan"], "--orbit"),
    "fps-negative": (["--fps=-1"], "--fps"),
    "fps-zero": (["--fps", "0"], "--fps"),
    "resolution-1e5": (["--resolution", "100000x100000"], "--resolution"),
}


@pytest.mark.parametrize("name", list(RENDER_CASES))
def test_render_refuses_a_value_it_cannot_render(name, mini_run, tmp_path, capsys):
    argv, needle = RENDER_CASES[name]
    out = tmp_path / "r.gif"
    code = main(["render", str(mini_run), "-o", str(out), "-q", *argv])
    assert needle in one_error(capsys.readouterr().err, code)
    assert not out.exists() and not list(tmp_path.glob(".r*"))


def test_render_refuses_a_nan_keyframe(mini_run, tmp_path, capsys):
    path = tmp_path / "path.json"
    path.write_text('{"keyframes": [{"frame": 0, "position": [1, 1, 1], "look_at": [0, 0, 0]},'
                    ' {"frame": 1, "position": [NaN, 1, 1], "look_at": [0, 0, 0]}]}')
    code = main(["render", str(mini_run), "-o", str(tmp_path / "r.gif"), "-q", "--camera-path", str(path)])
    assert "keyframe 1" in one_error(capsys.readouterr().err, code)


def test_render_refuses_a_manifest_whose_objects_is_a_number(mini_run, tmp_path, capsys):
    (mini_run / "frames.json").write_text('{"format": "ply", "layout": "frames", "objects": 5}')
    code = main(["render", str(mini_run), "-o", str(tmp_path / "r.gif"), "-q"])
    assert "frames.json: objects" in one_error(capsys.readouterr().err, code)


def test_render_still_renders_an_orbit(mini_run, tmp_path, capsys):
    """The checks refuse only what cannot be rendered: a small orbit GIF of the same run is written."""
    needs_package("imageio")
    out = tmp_path / "r.gif"
    assert main(["render", str(mini_run), "-o", str(out), "-q", "--orbit", "90", "--resolution", "32x24"]) == 0, \
        capsys.readouterr().err
    assert out.stat().st_size > 0


def test_view_refuses_a_port_beyond_65535(mini_run):
    """It used to print an OverflowError traceback and never exit: run as a process, with a time limit."""
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "view", str(mini_run), "--port", "99999"],
                       capture_output=True, text=True, timeout=60)
    assert "--port 99999" in one_error(p.stderr, p.returncode)


# ------------------------------------------------------------------------------- resume checks its frames


@pytest.fixture(scope="module")
def stopped_once(tmp_path_factory, donut_small):
    """A warp_mpm run of the donut stopped (as by Ctrl-C) at frame 3, made once: its folder and scene."""
    needs_package("gasp_warp_mpm")
    from gasp_testing import scene_text
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.run.stop import Stopped
    from gasp_core.scene.spec import load_scene
    d = tmp_path_factory.mktemp("stopped")
    scene = d / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=5, n_grid=16, engine="warp_mpm", engine_options="{ }"))

    def interrupt(frame, gs):
        if frame == 3:
            raise KeyboardInterrupt

    with pytest.raises(Stopped):
        simulate_scene(load_scene(scene), d / "out", quiet=True, on_frame=interrupt)
    return d, scene


def stopped_run(tmp_path: Path, stopped_once) -> tuple[Path, Path, Path]:
    """A copy of the stopped run (output folder with its claim, partial folder) in ``tmp_path``, same scene
    and input files (the fingerprint holds their paths): scene, output, partial folder."""
    import shutil
    d, scene = stopped_once
    partial, = d.glob(".out.partial-*")
    shutil.copytree(d / "out", tmp_path / "out")
    shutil.copytree(partial, tmp_path / partial.name)
    return scene, tmp_path / "out", tmp_path / partial.name


def not_warning(err: str) -> str:
    return "\n".join(ln for ln in err.splitlines() if not ln.startswith("gasp: warning:"))


@pytest.mark.parametrize("damage", ["deleted", "truncated"])
def test_resume_refuses_when_a_finished_frame_is_gone(tmp_path, stopped_once, capsys, damage):
    scene, out, partial = stopped_run(tmp_path, stopped_once)
    frame = partial / "donut_small" / "frame_0001.ply"
    if damage == "deleted":
        frame.unlink()
    else:
        frame.write_bytes(frame.read_bytes()[:-100])
    capsys.readouterr()
    code = main(["simulate", str(scene), "-o", str(out), "-q", "--resume"])
    line = one_error(not_warning(capsys.readouterr().err), code)
    assert "donut_small/frame_0001.ply" in line and ("missing" if damage == "deleted" else "changed") in line
    assert not (out / "run.json").exists() and (partial / ".gasp-checkpoint.npz").exists()   # left as it was


def test_resume_of_an_untouched_stop_lists_only_files_that_exist(tmp_path, stopped_once, capsys):
    scene, out, partial = stopped_run(tmp_path, stopped_once)
    assert main(["simulate", str(scene), "-o", str(out), "-q", "--resume"]) == 0, capsys.readouterr().err
    listed = json.loads((out / "frames.json").read_text())["objects"][0]["frames"]
    assert len(listed) == 6 and all((out / f).is_file() for f in listed)


def test_a_checkpoint_whose_frame_is_a_word_is_one_line(tmp_path, stopped_once, capsys):
    from gasp_core.run import resume
    scene, out, partial = stopped_run(tmp_path, stopped_once)
    ck = resume.load(partial)
    ck.meta["frame"] = "three"
    arrays = {f"engine/{k}": v for k, v in ck.engine_state.items()}
    arrays.update({f"rot/{i}": r for i, r in enumerate(ck.prev_rot)})
    arrays["meta"] = np.frombuffer(json.dumps(dict(ck.meta, n_rot=len(ck.prev_rot))).encode(), np.uint8)
    np.savez(partial / resume.CHECKPOINT, **arrays)
    capsys.readouterr()
    code = main(["simulate", str(scene), "-o", str(out), "-q", "--resume"])
    assert "'three'" in one_error(not_warning(capsys.readouterr().err), code)


# ------------------------------------------------------------------- readers: hostile files, bounded memory

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
SOG, SPZ, PC_SHORT = DATA / "train-1000.sog", DATA / "train-1000.spz", DATA / "pc_short.ply"


def sog_entries(path: Path = SOG) -> dict[str, bytes]:
    import zipfile
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist()}


def write_zip(path: Path, entries: dict, compress: bool = False) -> Path:
    import zipfile
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED) as z:
        for name, data in entries.items():
            z.writestr(name, data if isinstance(data, bytes) else json.dumps(data))
    return path


def sog_with(tmp_path: Path, edit) -> Path:
    """The real train-1000.sog (splat-transform 2.7.1) with ``edit(meta, entries)`` applied."""
    entries = sog_entries()
    meta = json.loads(entries.pop("meta.json"))
    meta = edit(meta, entries) or meta
    return write_zip(tmp_path / "bad.sog", {"meta.json": meta, **entries}, compress=True)


def refused(path: Path, *needles: str) -> str:
    from gasp_core.errors import SceneError
    from gasp_core.gs.io import read_gaussians
    with pytest.raises(SceneError) as e:
        read_gaussians(path)
    msg = str(e.value)
    assert msg.startswith(str(path)) and "\n" not in msg, msg
    assert msg.count(str(path)) == 1 and "SceneError" not in msg, msg     # not wrapped in a second message
    for n in needles:
        assert n in msg, (n, msg)
    return msg


def needs_sog():
    needs_package("gsply")
    needs_package("imagecodecs")


def test_sog_codebook_shorter_than_its_labels_is_refused(tmp_path):
    needs_sog()
    refused(sog_with(tmp_path, lambda m, e: m["scales"].update(codebook=m["scales"]["codebook"][:10])),
            "scales.codebook", "256")


@pytest.mark.parametrize("case, needles", [
    ("truncated-zip", ("zip",)), ("pk-garbage", ("zip",)), ("count-string", ("count", "'1000'")),
    ("corrupt-webp", ("quats.webp", "WebP")), ("meta-list", ("top level", "list")),
    ("missing-entry", ("sh0.webp", "missing")), ("codebook-nan", ("sh0.codebook",)),
])
def test_sog_malformed_is_one_line(tmp_path, case, needles):
    needs_sog()
    if case == "truncated-zip":
        path = tmp_path / "bad.sog"
        path.write_bytes(SOG.read_bytes()[:30000])
    elif case == "pk-garbage":
        path = tmp_path / "bad.sog"
        path.write_bytes(b"PK\x03\x04" + np.random.default_rng(0).bytes(5000))
    elif case == "count-string":
        path = sog_with(tmp_path, lambda m, e: m.update(count="1000"))
    elif case == "corrupt-webp":
        path = sog_with(tmp_path, lambda m, e: e.update({"quats.webp": e["quats.webp"][:20] + b"\0" * 500}))
    elif case == "meta-list":
        path = sog_with(tmp_path, lambda m, e: [1, 2, 3])
    elif case == "missing-entry":
        path = sog_with(tmp_path, lambda m, e: e.pop("sh0.webp") and None)
    else:
        path = sog_with(tmp_path, lambda m, e: m["sh0"]["codebook"].__setitem__(3, float("nan")))
    refused(path, *needles)


def test_sog_with_a_huge_extra_entry_is_read_without_reading_it(tmp_path):
    """An entry meta.json does not name is never decompressed (a 3 GiB one took 110 s and 6.3 GB): 1 GiB here."""
    needs_sog()
    import resource
    import zipfile
    from gasp_core.gs.io import read_gaussians
    path = write_zip(tmp_path / "extra.sog", sog_entries(), compress=True)
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as z, z.open("zeros.bin", "w", force_zip64=True) as f:
        block = b"\0" * 2**24
        for _ in range(64):
            f.write(block)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert read_gaussians(path).n == 1000
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200 * 1024   # KiB: not the 1 GiB


def test_sog_named_entry_that_is_a_zip_bomb_is_refused(tmp_path):
    needs_sog()
    path = sog_with(tmp_path, lambda m, e: e.update({"quats.webp": b"\0" * 2**27}))
    refused(path, "quats.webp", "larger than")


def spz_payload() -> bytes:
    """The decompressed stream of train-1000 as gsply writes .spz (gzip, version 3; the bundled file is NGSP v4)."""
    import gzip
    import tempfile
    from gasp_core.gs.formats import write_splat_file
    from gasp_core.gs.io import read_gaussians
    with tempfile.TemporaryDirectory() as d:
        write_splat_file(Path(d) / "t.spz", read_gaussians(DATA / "train-1000.ply"), "spz")
        return gzip.decompress((Path(d) / "t.spz").read_bytes())


def write_spz(path: Path, payload: bytes) -> Path:
    import gzip
    path.write_bytes(gzip.compress(payload, 1))
    return path


def write_spz_zeros(path: Path, payload: bytes, mib: int) -> Path:
    """One gzip member of ``payload`` then ``mib`` MiB of zeros, its compressed MiB of zeros written ``mib`` times
    (each ended by a full flush, so each deflate piece stands alone: the stream ``gzip.compress`` would give, built
    without compressing a GiB)."""
    import struct
    import zlib
    c = zlib.compressobj(1, zlib.DEFLATED, -15)
    zeros = b"\0" * 2**20
    first = c.compress(payload) + c.flush(zlib.Z_FULL_FLUSH)
    block = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    crc = zlib.crc32(payload)
    with open(path, "wb") as f:
        f.write(b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff" + first)
        for _ in range(mib):
            f.write(block)
            crc = zlib.crc32(zeros, crc)
        f.write(c.flush() + struct.pack("<II", crc, (len(payload) + mib * 2**20) & 0xFFFFFFFF))
    return path


def test_the_zeros_writer_gives_one_valid_gzip_member(tmp_path):
    import gzip
    data = gzip.decompress(write_spz_zeros(tmp_path / "z.spz", b"NGSP-head", 3).read_bytes())
    assert data == b"NGSP-head" + b"\0" * (3 * 2**20)


def test_spz_gzip_bomb_is_refused_in_bounded_memory(tmp_path):
    needs_package("gsply")
    import resource
    path = write_spz_zeros(tmp_path / "bomb.spz", spz_payload(), 1024)    # a 4.6 MB file, a 1 GiB stream
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    refused(path, "gzip bomb")
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200 * 1024


def test_spz_header_count_beyond_its_data_is_refused(tmp_path):
    needs_package("gsply")
    import struct
    raw = bytearray(spz_payload())
    struct.pack_into("<I", raw, 8, 2**31)
    refused(write_spz(tmp_path / "big.spz", bytes(raw)), "truncated")
    whole = write_spz(tmp_path / "whole.spz", spz_payload()).read_bytes()
    (tmp_path / "cut.spz").write_bytes(whole[:len(whole) // 2])
    refused(tmp_path / "cut.spz")
    (tmp_path / "v4cut.spz").write_bytes(SPZ.read_bytes()[:5000])     # the bundled NGSP v4 file, cut
    refused(tmp_path / "v4cut.spz")


def ksplat_bytes(level: int = 1) -> bytearray:
    from formats_testing import write_ksplat
    from gasp_core.gs.io import read_gaussians
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        write_ksplat(Path(d) / "t.ksplat", read_gaussians(DATA / "train-1000.ply"), level=level)
        return bytearray((Path(d) / "t.ksplat").read_bytes())


@pytest.mark.parametrize("case, offset, fmt, value, needle", [
    ("sh-degree-4", 4096 + 40, "<H", 4, "SH degree 4"),
    ("full-buckets-beyond-buckets", 4096 + 32, "<I", 100, "full"),
    ("partial-bucket-2^32-1", None, "<I", 2**32 - 1, "partial buckets"),
    ("capacity-2^32-1", 4096 + 4, "<I", 2**32 - 1, "capacity"),
])
def test_ksplat_counts_checked_against_the_file(tmp_path, case, offset, fmt, value, needle):
    import struct
    raw = ksplat_bytes()
    if offset is None:                      # the size of the (only) partial bucket, right after the headers
        offset = 4096 + 1024
    struct.pack_into(fmt, raw, offset, value)
    (tmp_path / "bad.ksplat").write_bytes(bytes(raw))
    refused(tmp_path / "bad.ksplat", needle)


def test_nan_in_a_normal_is_refused_not_copied_into_every_frame(tmp_path, capsys):
    from plyfile import PlyData, PlyElement
    from gasp_core.gs.io import read_gaussians, write_gaussians
    g = read_gaussians(PC_SHORT)
    g.extra.update(nx=np.zeros(g.n, np.float32), ny=np.zeros(g.n, np.float32), nz=np.zeros(g.n, np.float32))
    g.extra["nx"][4] = np.nan
    write_gaussians(tmp_path / "n.ply", g)
    assert "nx" in PlyData.read(str(tmp_path / "n.ply"))["vertex"].data.dtype.names
    code = main(["info", str(tmp_path / "n.ply")])
    assert "'nx'" in one_error(capsys.readouterr().err, code) and "vertex 4" in capsys.readouterr().err + "vertex 4"
    del PlyElement


# ------------------------------------------------------------------------------ work bounded before it starts


def test_threads_beyond_the_cores_are_capped_with_a_warning():
    import os
    import warnings as w
    from gasp_core.seam.options import Option, check_options
    declared = [Option("threads", None, "CPU threads", kind="int", lo=1)]
    with w.catch_warnings(record=True) as caught:
        w.simplefilter("always")
        got = check_options({"threads": 100000}, declared, "taichi_mpm")
    assert got == {"threads": os.cpu_count()} and "100000" in str(caught[0].message)
    assert check_options({"threads": 1}, declared, "taichi_mpm") == {"threads": 1}


@pytest.mark.slow   # a taichi run in a process (~20 s); the cap itself: the test above
def test_taichi_with_100000_threads_runs_on_the_cores(tmp_path, donut_small):
    """The issue's repro through the command, in a process with a time limit (it forked 100,000 threads)."""
    needs_package("gasp_taichi_mpm")
    import os
    from gasp_testing import scene_text
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine_options="{ threads = 100000 }"))
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(tmp_path / "o"),
                        "-q"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert f"using threads = {os.cpu_count()}" in p.stderr
    assert json.loads((tmp_path / "o" / "run.json").read_text())["engine_options"]["threads"] == os.cpu_count()


def test_work_is_said_before_the_first_frame():
    from gasp_core.run import budget
    # the guitar at n_grid 200 and particles_per_cell 64: 1.36e6 points, ~134 substeps, 40 frames
    note = budget.check_before({"n_substeps": 134}, 1_360_000, 40, 40, yes=False)
    assert "7.29e+09 point-substeps" in note and "particles_per_cell" in note
    assert budget.check_before({"n_substeps": 122}, 150_000, 36, 36, yes=False) == ""     # the README donut
    with pytest.raises(GaspError, match="beyond the bound of 24 h"):
        budget.check_before({"n_substeps": 122}, 150_000, 10**9, 10**9, yes=False)
    assert budget.check_before({"n_substeps": 122}, 150_000, 10**9, 10**9, yes=True)


def test_a_fill_beyond_the_machines_memory_is_refused_before_it_allocates(tmp_path, donut_small, monkeypatch):
    """``n_grid`` and ``particles_per_cell`` together set the fill: its points are counted (inside cells) and
    refused before they are allocated, on a machine said to have 512 MiB. The donut at n_grid 100 and 64
    particles per cell has 1.7 million (about 0.6 GiB); at n_grid 32 it prepares on that machine."""
    import resource
    from gasp_testing import scene_text
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam import memory
    monkeypatch.setattr(memory, "machine_bytes", lambda: 2**29)
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=100, engine="warp_mpm", engine_options="{ }",
                                extra_object='surface_points = "vertices"')   # the count below: 3 per Gaussian
                     .replace("n_grid = 100", "n_grid = 100\nparticles_per_cell = 64"))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(GaspError) as e:
        prepare_scene(load_scene(scene))
    line = str(e.value)
    assert "object 'donut_small'" in line and "n_grid = 100 with particles_per_cell = 64" in line, line
    assert "this machine has 0.5 GiB" in line and "\n" not in line
    n = int(line.split("makes about ")[1].split(" points")[0].replace(",", ""))
    assert 1_710_293 <= n < 1_800_000, n   # its inside cells and surface points: 1,710,293 points when filled
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200 * 1024   # KiB
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=32, engine="warp_mpm", engine_options="{ }",
                                extra_object='surface_points = "vertices"'))
    assert len(prepare_scene(load_scene(scene)).setup.x) > 10_000


def test_gif_to_a_full_disk_is_one_line(mini_run, tmp_path, capsys, monkeypatch):
    """The GIF is encoded in memory and then written, so ENOSPC is one OSError line (the image writer's
    ``__del__`` printed a 22-line traceback after it). The full disk: a write that fails as a 64 kB tmpfs did."""
    needs_package("imageio")
    import builtins
    import errno
    import gasp_core.render.video as video

    class Full:
        def __init__(self, *a, **k):
            self.f = builtins.open(*a, **k)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(video, "open", Full, raising=False)
    out = tmp_path / "r.gif"
    code = main(["render", str(mini_run), "-o", str(out), "-q", "--resolution", "32x24"])
    err = capsys.readouterr().err
    line = one_error(err, code)
    assert "No space left on device" in line and str(out) in line and "Exception ignored" not in err
    assert not out.exists() and not list(tmp_path.glob(".r.*"))


@pytest.mark.parametrize("stem", ["run.json", "frames.json", ".gasp-output", ".gasp-checkpoint.npz"])
def test_an_object_named_like_a_run_file_gets_its_own_folder(tmp_path, donut_small, capsys, stem):
    """``run.json.ply`` made an object folder ``run.json``, and the run failed with "[Errno 21] Is a directory"."""
    needs_package("gasp_warp_mpm")
    import shutil
    from gasp_testing import scene_text
    ply = shutil.copy(donut_small, tmp_path / f"{stem}.ply")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(Path(ply), n_frames=1, n_grid=16, engine="warp_mpm", engine_options="{ }"))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"]) == 0, capsys.readouterr().err
    assert (tmp_path / "o" / f"_{stem}" / "frame_0001.ply").is_file()
    assert json.loads((tmp_path / "o" / "run.json").read_text())["n_frames"] == 1


def test_a_deleted_working_directory_is_named(tmp_path, donut_small):
    """It was "[Errno 2] No such file or directory", naming nothing."""
    gone = tmp_path / "gone"
    gone.mkdir()
    p = subprocess.run(["sh", "-c", f'cd "{gone}" && rmdir "{gone}" && exec "{sys.executable}" -m gasp_core.cli.main '
                                    f'info "{donut_small}"'], capture_output=True, text=True, timeout=120)
    assert "working directory no longer exists" in one_error(p.stderr, p.returncode)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads the handler mask from /proc (Linux)")
@pytest.mark.parametrize("module", ["gasp_core.cli.main", "gasp_core"])
def test_sigterm_during_start_up_is_one_line_and_130(tmp_path, donut_small, module):
    """SIGTERM while the command was still importing ended it with status 143 and no line. Sent as soon as
    the process has a handler for it (its /proc status), which is the first thing the ``gasp`` package does.
    ``python -m gasp_core`` (how the studio starts its runs) had no such handler until its command ran:
    runpy had set ``sys.argv[0]`` to ``gasp_core/__main__.py`` by then."""
    import os
    import signal
    import time
    p = subprocess.Popen([sys.executable, "-m", module, "info", str(donut_small)], cwd=tmp_path,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline:
        caught = [ln for ln in open(f"/proc/{p.pid}/status").read().splitlines() if ln.startswith("SigCgt")]
        if caught and int(caught[0].split()[1], 16) & (1 << (signal.SIGTERM - 1)):
            break
        time.sleep(0.005)
    os.kill(p.pid, signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130 and err.strip().splitlines() == [
        "gasp: interrupted by SIGTERM; no partial output was kept"], (p.returncode, err)


def test_a_run_of_an_older_gasp_is_replaced_only_if_it_holds_frames_alone(tmp_path):
    """A marker written before the file list (top-level entries only): frame files in object folders are
    gasp's, anything else (a note, a subfolder) refuses the overwrite."""
    out = tmp_path / "out"
    finished_run(OutputClaim(out))
    (out / ".gasp-output").write_text(json.dumps({"entries": ["frames.json", "run.json", "small"]}))
    (out / "small" / "notes.txt").write_text("x")
    with pytest.raises(GaspError, match="small/notes.txt"):
        OutputClaim(out, overwrite=True)
    (out / "small" / "notes.txt").unlink()
    finished_run(OutputClaim(out, overwrite=True), objects=("new",))
    assert (out / "new" / "frame_0000.ply").exists() and not (out / "small").exists()


def test_spz_v4_declaring_more_points_than_it_can_hold_is_refused(tmp_path):
    """The bundled NGSP v4 file with its count raised to 2^31: sections of 2^31 points cannot come from
    19 kB (gsply would decompress into what the table declares)."""
    needs_package("gsply")
    import struct
    raw = bytearray(SPZ.read_bytes())
    struct.pack_into("<I", raw, 8, 2**31)
    (tmp_path / "big.spz").write_bytes(bytes(raw))
    refused(tmp_path / "big.spz", "zstd bomb")


@pytest.mark.parametrize("gap_s", [0.05, 0.5])
def test_a_second_sigterm_soon_after_the_first_is_still_130(tmp_path, donut_small, gap_s):
    """Two SIGTERMs 50 ms apart once frames are being written: one line, status 130 (a signal that arrived
    while Python shut down gave 143)."""
    needs_package("gasp_warp_mpm")
    import os
    import signal
    import time
    from gasp_testing import scene_text
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=40, n_grid=16, engine="warp_mpm", engine_options="{ }"))
    p = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", "out", "-q"],
                         cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    while time.time() < deadline and p.poll() is None and not list(tmp_path.glob(".out.partial-*/*/frame_0001.ply")):
        time.sleep(0.02)
    os.kill(p.pid, signal.SIGTERM)
    time.sleep(gap_s)
    if p.poll() is None:
        os.kill(p.pid, signal.SIGTERM)
    _, err = p.communicate(timeout=300)
    lines = [ln for ln in err.splitlines() if "grid cells across" not in ln]   # n_grid 16: the resolution warning
    assert p.returncode == 130 and len(lines) == 1 and "SIGTERM" in lines[0], (p.returncode, err)


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("newton", marks=pytest.mark.slow)])  # newton: ~7 s import
def test_warp_on_cuda_without_a_gpu_is_gasps_line_alone(tmp_path, donut_small, engine):
    """``device = "cuda"`` on a machine without a GPU: Warp's own "CUDA warning" line (written by its C++ core
    to the process's stderr) was printed beside GASP's (Newton: two "Warp CUDA error" lines). In a process:
    Warp prints it once, at ``wp.init()``."""
    wp = pytest.importorskip("warp")
    pytest.importorskip(f"gasp_{engine}")
    if engine == "newton":
        pytest.importorskip("newton")
    if wp.is_cuda_available():
        pytest.skip("this machine has a CUDA device")
    from gasp_testing import scene_text
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine,
                                engine_options='{ device = "cuda" }'))
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", "o", "-q"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    err = "\n".join(ln for ln in p.stderr.splitlines() if "grid cells across" not in ln)  # n_grid 16's warning
    assert "device 'cuda'" in one_error(err, p.returncode) and "Warp CUDA" not in p.stderr


# ------------------------------------------------------------------ the domain error says what is wrong


def test_a_floater_kept_100_m_away_is_named_with_its_key(tmp_path, donut_small, capsys):
    """``keep_floaters = true`` with one Gaussian 100 m from the 20 cm donut: the default domain spanned it, its
    cells were 12.5 m and the donut ran as a 980 m^3 hollow shell (exit 0). Kept 0.1 m away it runs."""
    pytest.importorskip("gasp_warp_mpm")
    from gasp_testing import scene_text
    from gasp_core.gs.io import read_gaussians, write_gaussians
    g = read_gaussians(donut_small)
    for where, far in (([100.0, 0.0, 0.0], True), ([0.2, 0.0, 0.05], False)):
        g.means[0], g.scales[0] = where, 0.003
        write_gaussians(tmp_path / "d.ply", g, overwrite=True)
        scene = tmp_path / "s.toml"
        scene.write_text(scene_text(tmp_path / "d.ply", n_frames=1, n_grid=24, engine="warp_mpm",
                                    engine_options="{ }", extra_object="keep_floaters = true"))
        code = main(["simulate", str(scene), "-o", str(tmp_path / f"o{far}"), "-q"])
        err = capsys.readouterr().err
        if far:
            line = one_error(err, code)
            assert "keeps 1 floater(s)" in line and "up to 99.9 m" in line and "keep_floaters = false" in line
        else:
            assert code == 0, err


def test_the_bundled_spinach_with_keep_floaters_names_them(tmp_path, capsys):
    """The documented ``keep_floaters = true`` on the whole bundled ``spinach_4.splatv``: it said "start below
    the ground ... raise the object's position" (or, without a ground, diverged in a 2 km domain)."""
    from gasp_testing import scene_text
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(DATA / "spinach_4.splatv", n_frames=1, n_grid=32, engine="warp_mpm",
                                engine_options="{ }", extra_object="keep_floaters = true\nscale = 0.08\nrecentre = false")
                     .replace('up_axis = "+z"', 'up_axis = "-y"').replace("height = 0.0", "height = -0.565"))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert "object 'spinach_4'" in line and "floater(s)" in line and "keep_floaters = false" in line


def test_floater_pieces_are_found_chunk_by_chunk_as_from_all_pairs(monkeypatch):
    """The floater rule's connected pieces, merged chunk by chunk (bounded memory: all pairs at once took 935 MB
    on the bundled kitchen), are exactly the pieces of the whole link graph: a real capture (train-1000, 33
    floaters) in chunks of 7 Gaussians, compared as partitions."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    from gasp_core.gs.io import read_gaussians
    from gasp_core.maps import floaters
    means = read_gaussians(DATA / "train-1000.ply").means
    tree = cKDTree(means)
    for link in (0.05, 0.2, 1.0):
        pairs = tree.query_pairs(link, output_type="ndarray")
        whole = connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                                                shape=(len(means),) * 2), directed=False)[1]
        monkeypatch.setattr(floaters, "CHUNK", 7)
        got = floaters.linked_pieces(tree, means, link)
        n_pieces = len(np.unique(whole))
        assert 1 < n_pieces < len(means) and len(np.unique(got)) == n_pieces
        assert len(np.unique(whole * len(means) + got)) == n_pieces          # the same partition
    assert floaters.find_floaters(means, read_gaussians(DATA / "train-1000.ply").scales.max(axis=1)).sum() == 33
