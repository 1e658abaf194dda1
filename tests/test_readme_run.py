"""The README run as a user types it (issue 55): every command line of its code blocks and tables, from a copy of
the clone, checked for its exit code, the files it names and the figures it states.

Every command line of the README (readme_lines.py finds them) runs from a temporary copy of the clone, in the
README's order (the quick start's out/donut feeds the lines after it). The default tier cuts every simulation
to CUT frames (the heavy scenes, listed in HEAVY, run in the slow tier only); the slow tier runs every line
whole and checks the figures the README states of a whole run. After each line, nothing may lie in the copy's
root but out/ (the lines' outputs belong under the ignored out/). Times the README states are not asserted (no
timed assertions in tests): docs/performance.md and benchmarks/ measure them. The static checks of the README
(links, the parser, the snippet): tests/test_readme.py.
"""
import json
import re
import subprocess

import pytest

import readme_lines as rl
from gasp_testing import needs_package

CUT = 1
#: Lines whose scenes take minutes even cut (a 272,562-point guitar, the kitchen, two engines): slow tier only.
HEAVY = ("guitar_sand.toml", "kitchen_spinach.toml", "donut_on_guitar.toml", "gasp compare")
#: The page the README donut exports must stay under this (issue 55), and its stated size within PAGE_TOL.
PAGE_LIMIT, PAGE_TOL = 5.0e6, 0.05


def readme() -> str:
    return rl.README.read_text(encoding="utf-8")


def stated(pattern: str) -> re.Match:
    m = re.search(pattern, re.sub(r"\s+", " ", readme()))   # a stated line may wrap
    assert m, f"the README no longer states {pattern!r}"
    return m


def frame_files(folder, n):
    return [folder / f"frame_{k:04d}.ply" for k in range(n + 1)]


def check_quick_start(res, copy, frames):
    m = stated(r"It writes (\d+) simulated frames \(([\d.]+) s of motion\)")
    n = frames or int(m.group(1))
    missing = [p for p in frame_files(copy / "out/donut/donut_v3dg", n) if not p.is_file()]
    assert not missing and (copy / "out/donut/run.json").is_file(), missing
    last = stated(r"`(wrote 37 frames \(frame 0 = the input\) x 1 object\(s\) to out/donut \((\d+) simulated points, "
                  r"(\d+) substeps/frame), \.\.\.\)`")
    want = last.group(1).replace("wrote 37 frames", f"wrote {n + 1} frames")
    assert want in res.stdout, f"README: {want!r}; the run: {res.stdout.strip().splitlines()[-1:]}"
    record = json.loads((copy / "out/donut/run.json").read_text())
    if frames is None:
        assert abs(record["n_frames"] * record["frame_dt"] - float(m.group(2))) < 0.05, record["n_frames"]


def check_resume(res, copy, frames):
    """After the quick start the run is finished: --resume says so and what --overwrite would do (it called it a
    blow-up). Then what the row promises: a run stopped by Ctrl-C continues and finishes."""
    assert res.returncode != 0 and "finished" in res.stderr and "--overwrite" in res.stderr, res.stderr
    assert "diverged" not in res.stderr and "Traceback" not in res.stderr, res.stderr
    n = (frames or 34) + 2      # Ctrl-C after frame 1, with frames left to go
    step = rl.cut_frames("gasp simulate examples/donut_jelly.toml -o out/donut_stop --json", n)
    p = subprocess.Popen(rl.shlex.split(step), cwd=copy, env=rl.env(), stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True, start_new_session=True)
    for ln in p.stdout:
        if json.loads(ln).get("event") == "frame" and json.loads(ln)["frame"] >= 1:
            p.send_signal(rl.signal.SIGINT)   # Ctrl-C after the first frame
            break
    assert p.wait(120) == 130
    again = rl.run_line(rl.cut_frames("gasp simulate examples/donut_jelly.toml -o out/donut_stop --resume", n), copy)
    assert again.returncode == 0, again.stderr
    assert all(p.is_file() for p in frame_files(copy / "out/donut_stop/donut_v3dg", n))


def check_page(res, copy, frames):
    argv = rl.shlex.split(res.args[-1])
    page = copy / argv[argv.index("--export") + 1]      # where the line writes it
    size = page.stat().st_size
    assert size < PAGE_LIMIT, f"the README donut's page is {size / 1e6:.2f} MB, over {PAGE_LIMIT / 1e6:.0f} MB"
    said = float(stated(r"one self-contained page \(([\d.]+) MB\)").group(1)) * 1e6
    if frames is None:
        assert abs(size / said - 1) <= PAGE_TOL, f"README: {said / 1e6} MB; the page: {size / 1e6:.2f} MB"


def check_json(res, copy, frames):
    """One JSON object per line: a ``frame`` event per frame (frame 0, the input, first), then a ``result`` naming
    the ``run.json`` it wrote."""
    events = [json.loads(ln) for ln in res.stdout.splitlines()]
    n = frames or 36
    assert [e["frame"] for e in events if e["event"] == "frame"] == list(range(n + 1)), events
    assert events[-1]["event"] == "result" and (copy / events[-1]["run_json"]).is_file(), events[-1]
    assert not [e for e in events if e["event"] == "error"]


def check_server(res, copy, frames):
    """A server line printed its URL and served the page there; the studio's URL carries its token, as the README
    shows, and the bare address is refused (403), as the README says."""
    url, out, (status, bare) = res
    assert url, out
    if "?token=" in url:
        assert "/?token=" in readme() and bare == 403, (url, bare)
    else:
        said = stated(r"plays in the browser at (http://\S+)").group(1)
        assert url.rsplit(":", 1)[0] == said.rsplit(":", 1)[0], (url, said)
    assert status == 200, (url, status, out)


def check_info(res, copy, frames):
    """The summary with the mass at the density given (it failed: the path read twice)."""
    mass = re.search(r"mass_kg: ([\d.e+-]+)", res.stdout)
    assert mass and float(mass.group(1)) > 0, res.stdout


def check_draft(res, copy, frames):
    """``--quality draft`` simulates no more points than the README's ``default`` run states (it had 151,503 against
    65,036; the time per frame of every example: benchmarks/bench_draft.py)."""
    default = int(stated(r"\((\d+) simulated points, \d+ substeps/frame, \.\.\.\)").group(1))
    draft = json.loads((copy / "out/draft/run.json").read_text())["n_points"]
    assert 0.5 * default < draft <= default, (draft, default)


def check_compare(res, copy, frames):
    """The report is written; nothing of Dask's is shown as GASP's, and the report does not call the engines'
    runs one-thread."""
    assert (copy / "out/compare/report.md").is_file()
    assert "8787" not in res.stderr, res.stderr
    assert "one-thread worker" not in (copy / "out/compare/report.md").read_text()


def exists(*paths):
    def check(res, copy, frames):
        missing = [p for p in paths if not (copy / p).exists()]
        assert not missing, f"the line does not write {missing}"
    return check


def http_status(url):
    import urllib.error
    import urllib.request
    try:
        with urllib.request.urlopen(url, timeout=30) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


#: The quick start's line: the lines after it that read its ``out/donut`` need it run first in their copy.
QUICK_START = "gasp simulate examples/donut_jelly.toml -o out/donut"


#: What each line must show beyond exit code 0 (keyed by a piece of the step), and the package it needs.
CHECKS = {
    "gasp simulate examples/donut_jelly.toml -o out/donut --resume": (check_resume, None),
    QUICK_START: (check_quick_start, "gasp_taichi_mpm"),
    "gasp info examples/data/donut_v3dg.ply --rho 300": (check_info, None),
    "--engine warp_mpm -o out/donut_warp": (exists("out/donut_warp/run.json"), "gasp_warp_mpm"),
    "guitar_sand.toml -o out/guitar": (exists("out/guitar/run.json"), None),
    "kitchen_spinach.toml -o out/kitchen": (exists("out/kitchen/run.json"), None),
    "donut_on_guitar.toml -o out/on_guitar": (exists("out/on_guitar/run.json"), None),
    "donut_mesh.toml -o out/donut_mesh": (exists("out/donut_mesh/run.json"), "trimesh"),
    "donut_wood.toml -o out/wood": (exists("out/wood/run.json"), None),
    "--quality draft -o out/draft": (check_draft, None),
    "--format spz -o out/donut_spz": (exists("out/donut_spz/donut_v3dg/frame_0000.spz"), "gsply"),
    "gasp export out/donut --format usd": (exists("out/donut.usdc"), "pxr"),
    "gasp simulate examples/donut_jelly.toml -o out/donut_json --json": (check_json, None),
    "gasp compare": (check_compare, "gasp_warp_mpm"),
    "gasp export-soup": (exists("out/soup"), None),
    "gasp render out/donut --orbit": (exists("out/orbit.mp4"), "imageio"),
    "gasp render out/donut": (exists("out/donut/render.mp4"), "imageio"),
    "gasp view out/donut --export": (check_page, None),
    "gasp view out/donut": (check_server, "viser"),
    "gasp studio": (check_server, "viser"),
    "gasp engines": (lambda r, c, f: None, None),
}
FAILS_BY_DESIGN = ("--resume",)   # lines whose first run must fail with a message (checked by their function)
SERVERS = ("gasp view out/donut", "gasp studio")


def check_for(step: str):
    """The CHECKS entry of ``step``: its own, else the longest key it contains."""
    keys = [step] if step in CHECKS else sorted((k for k in CHECKS if k in step), key=len)
    if not keys:
        pytest.fail(f"README line with no check in tests/test_readme.py CHECKS: {step}")
    return keys[-1], CHECKS[keys[-1]]


STEPS = list(dict.fromkeys(s for ln in rl.readme_lines() for s in ln.steps if not rl.why_not_run(s)))


def test_every_readme_line_is_run_or_says_why():
    """Each step of each command line is run by the tests below, or not run for a reason this file states."""
    lines = rl.readme_lines()
    assert len(lines) >= 20 and any("--rho 300" in ln.text for ln in lines)
    for ln in lines:
        for s in ln.steps:
            assert rl.why_not_run(s) or check_for(s), s
    assert len(STEPS) >= 18, STEPS


def reads_quick_start(step: str) -> bool:
    """Whether ``step`` reads the quick start's ``out/donut`` (``--resume`` of it, render, view, export)."""
    return step != QUICK_START and re.search(r"out/donut(\s|$)", step) is not None


def run_step(step: str, copy, frames):
    key, (check, package) = check_for(step)
    if package:
        needs_package(package)
    if reads_quick_start(step) and not (copy / "out/donut/run.json").is_file():
        # round 79: a tier run alone (the slow tier holds the cut --resume line, the default tier the quick start)
        # found no out/donut; the README's order is kept by running the quick start first, as a user would have
        first = rl.run_line(rl.cut_frames(QUICK_START, frames), copy)
        assert first.returncode == 0, f"{QUICK_START}: exit {first.returncode}: {first.stderr[-2000:]}"
    before = set(rl.stray_files(copy))
    if key in SERVERS and "--export" not in step:
        res = rl.serve_and_stop(step, copy, lambda url: (http_status(url), http_status(url.split('?')[0])))
    else:
        res = rl.run_line(rl.cut_frames(step, frames), copy)
        if not any(f in key for f in FAILS_BY_DESIGN):
            assert res.returncode == 0, f"{step}: exit {res.returncode}: {res.stderr[-2000:]}"
    check(res, copy, frames)
    stray = sorted(set(rl.stray_files(copy)) - before)
    assert not stray, f"{step} wrote {stray} outside out/"


@pytest.fixture(scope="module")
def cut_copy(tmp_path_factory):
    return rl.clone(tmp_path_factory.mktemp("clone_cut"))


@pytest.fixture(scope="module")
def whole_copy(tmp_path_factory):
    return rl.clone(tmp_path_factory.mktemp("clone_whole"))


@pytest.mark.parametrize("step", [s for s in STEPS if not any(h in s for h in HEAVY)])
def test_readme_line_runs_cut(step, cut_copy):
    """The line as typed, its simulation cut to CUT frames: exit code, the files it names, what it promises."""
    run_step(step, cut_copy, CUT)


@pytest.mark.slow
@pytest.mark.parametrize("step", STEPS)
def test_readme_line_runs_whole(step, whole_copy):
    """The line as typed, whole: also the figures the README states of the whole run (frames, page size)."""
    run_step(step, whole_copy, None)
