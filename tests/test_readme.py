"""The README stays a five-minute read whose commands run as written, and no page of the docs links nowhere (issue 33).

Static checks only (no simulation): the size, every relative link of README.md and docs/*.md, every ``gasp``
command of the README parsed by the real CLI parser, the paths those commands name, the test command against
``.ci/run``, the README's scene snippet through the real scene loader, and a home in docs/ for every section
the README used to hold.
"""
import re
import shlex
from pathlib import Path

import pytest

from gasp_core.cli.main import build_parser
from gasp_core.scene.spec import load_scene

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.S | re.M)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def readme() -> str:
    return README.read_text(encoding="utf-8")


def prose(text: str) -> str:
    """``text`` without fenced code blocks and inline code, where ``[x](y)`` is not a link."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def relative_links(path: Path) -> list[str]:
    return [t for t in LINK.findall(prose(path.read_text(encoding="utf-8")))
            if not re.match(r"^[a-z][a-z0-9+.-]*:", t) and not t.startswith("#")]


def shell_lines(text: str) -> list[str]:
    """The commands of the README's ``bash`` blocks and of its inline code that starts with ``gasp`` or
    ``python``: one string per command, ``&&`` chains split, comments dropped."""
    lines = []
    for m in re.finditer(r"^```bash\n(.*?)^```", text, re.S | re.M):
        lines += [ln.split(" #")[0].strip() for ln in m.group(1).splitlines()]
    lines += re.findall(r"`((?:gasp|python) [^`\n]+)`", prose_code_only(text))
    return [c.strip() for ln in lines for c in ln.split("&&") if c.strip()]


def prose_code_only(text: str) -> str:
    return FENCE.sub("", text)


def test_readme_is_at_most_12_kb():
    size = len(README.read_bytes())
    assert size <= 12288, f"README.md is {size} bytes; move detail into docs/ (issue 33: at most 12 KB)"


@pytest.mark.parametrize("page", [README, *sorted((ROOT / "docs").glob("*.md"))], ids=lambda p: p.name)
def test_every_relative_link_resolves(page):
    missing = []
    for target in relative_links(page):
        path = (page.parent / target.split("#")[0]).resolve()
        if not path.exists() or ROOT not in path.parents:
            missing.append(target)
    assert not missing, f"{page.relative_to(ROOT)}: links to nothing in the repository: {missing}"


def test_link_check_sees_links_and_skips_code(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("[a](x.md) ![b](img/y.png) [c](https://e.org) [d](#anchor) `[e](no.md)`\n"
                    "```\n[f](no2.md)\n```\n", encoding="utf-8")
    assert relative_links(page) == ["x.md", "img/y.png"]


def test_every_gasp_command_of_the_readme_parses():
    """Each ``gasp ...`` line is accepted by the real parser: no command or flag the CLI lacks."""
    commands = [c for c in shell_lines(readme()) if c.startswith("gasp ")]
    assert len(commands) >= 12, commands
    names = {"simulate", "render", "view", "info", "engines", "compare", "export-soup"}
    assert names <= {shlex.split(c)[1] for c in commands}
    parser = build_parser()
    subcommands = parser._subparsers._group_actions[0].choices
    for c in commands:
        argv = shlex.split(c)[1:]
        assert argv[0] in subcommands, f"README names a command the CLI lacks: {c}"
        if len(argv) == 1 and argv[0] not in ("engines", "plugins"):
            continue   # a command named in the text (`gasp import-motion`), not one to run
        try:
            parser.parse_args(argv)
        except SystemExit as e:  # GaspArgumentParser: one line, exit 2
            pytest.fail(f"README command does not parse ({e.code}): {c}")


def test_paths_the_readme_commands_read_exist():
    """Scene files, data and plugin folders named by the README's commands are in the repository."""
    words = [w for c in shell_lines(readme()) for w in shlex.split(c)]
    inputs = [w.strip('"').split("[")[0].rstrip(".") for w in words
              if w.strip('"').startswith(("examples/", "plugins/"))]
    assert "examples/donut_jelly.toml" in inputs and "plugins/taichi_mpm" in inputs
    missing = [p for p in inputs if not (ROOT / p).exists()]
    assert not missing, missing


def test_test_command_is_what_ci_installs_and_runs():
    """Issue 42, item 5: .ci/run runs the README's two 'Tests' lines as written (the tools from outside PyPI,
    then the install and pytest), and the install carries playwright (the browser extra)."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    block = re.search(r"\n## Tests\n(.*?)\n## ", readme(), re.S).group(1)
    tools, command = [c.strip() for c in re.findall(r"^```bash\n(.*?)^```", block, re.S | re.M)]
    assert command.startswith("python -m pip install -e ") and command.endswith(" && python -m pytest")
    assert command in ci, "README's test command differs from .ci/run's"
    assert "browser" in re.search(r'"\.\[([a-z,]+)\]"', command).group(1).split(",")
    assert tools.startswith("apt-get") and "chromium" in tools and "splat-transform" in tools
    assert any(ln == f"{tools} \\" or ln == tools for ln in ci), "the tools line differs from .ci/run's"
    import tomllib
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert any(d.startswith("playwright") for d in extras["browser"])


def test_quick_start_is_one_command_that_installs_and_simulates():
    block = re.search(r"## Quick start\n(.*?)\n## ", readme(), re.S).group(1)
    code = re.findall(r"^```bash\n(.*?)^```", block, re.S | re.M)
    assert len(code) == 1 and len(code[0].strip().splitlines()) == 1, code
    steps = [s.strip() for s in code[0].split("&&")]
    assert steps[0].startswith("python -m venv") and steps[-1].startswith("gasp simulate examples/donut_jelly.toml")
    assert "python -m pip install -e . -e plugins/taichi_mpm" in steps


def test_readme_scene_snippet_loads(tmp_path):
    """The README's TOML, saved in examples/ as it says, is a valid scene (checked by the real loader)."""
    snippet = re.search(r"^```toml\n(.*?)^```", readme(), re.S | re.M).group(1)
    (tmp_path / "data").symlink_to(ROOT / "examples" / "data")
    (tmp_path / "mine.toml").write_text(snippet, encoding="utf-8")
    scene = load_scene(tmp_path / "mine.toml")
    assert scene.engine.name == "taichi_mpm" and len(scene.objects) == 1
    assert scene.objects[0].material.name == "jelly"


#: Every section the README held before issue 33, and the page of docs/ that holds it now.
MOVED = {
    "cli.md": ["## Commands", "## What `gasp simulate` writes", "## See the result"],
    "reliability.md": ["## Reliability", "## The test suite", "## Conformance", "## Known limits"],
    "scene_reference.md": ["## Scene files", "## Inputs", "## Surface points: `surface`",
                           "## Part of a scene: `select` and `static`", "## Colliders, impulses and forces"],
    "engines.md": ["## Engines", "## Speed and accuracy", "### Quality levels"],
    "design.md": ["## The method", "## Layout", "## Writing an engine plugin", "## Data and licences"],
}


@pytest.mark.parametrize("page", sorted(MOVED))
def test_sections_moved_out_of_the_readme_live_in_docs(page):
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    lines = text.splitlines()
    missing = [h for h in MOVED[page] if not any(ln.startswith(h) for ln in lines)]
    assert not missing, f"docs/{page} lacks {missing}"
    assert f"docs/{page}" in readme(), f"the README does not link docs/{page}"


def engine_table() -> dict[str, dict[str, set[str]]]:
    """The README's engine table: engine -> materials, boundaries, devices (``same`` = the row above's)."""
    block = re.search(r"## Engines\n(.*?)\n## ", readme(), re.S).group(1)
    rows, prev = {}, None
    for ln in block.splitlines():
        m = re.match(r"\| `(\w+)` \| (.*?) \| (.*?) \| (.*?) \|", ln)
        if m:
            cells = [prev[k] if c.startswith("same") else {w.strip() for w in c.split(",")}
                     for k, c in zip(("materials", "boundaries", "devices"), m.groups()[1:])]
            prev = rows[m.group(1)] = dict(zip(("materials", "boundaries", "devices"), cells))
    return rows


def test_engine_table_matches_what_each_engine_declares():
    """Each engine the README lists with its materials, boundaries and devices, as its plugin declares them
    (a plugin whose engine package is missing still registers its record: ``gasp engines`` lists it)."""
    from gasp_core.seam.plugins import engines
    table, found = engine_table(), engines()
    assert set(table) == {"taichi_mpm", "warp_mpm", "mujoco_flex", "newton", "genesis", "blender"}
    checked = 0
    for name, row in table.items():
        if name not in found:
            continue   # its plugin distribution is not installed here
        c = found[name].capabilities
        assert row == {"materials": set(c.materials), "boundaries": set(c.boundaries),
                       "devices": set(c.devices)}, name
        checked += 1
    assert checked >= 1
    assert re.search(r"six\s+ship here", readme()), "the README's count of engines"


def test_scene_reference_example_loads(tmp_path):
    """The full example of docs/scene_reference.md ("Scene files") is a valid scene for the real loader."""
    text = (ROOT / "docs" / "scene_reference.md").read_text(encoding="utf-8")
    example = re.search(r"## Scene files\n.*?^```toml\n(.*?)^```", text, re.S | re.M).group(1)
    (tmp_path / "data").symlink_to(ROOT / "examples" / "data")
    (tmp_path / "full.toml").write_text(example, encoding="utf-8")
    scene = load_scene(tmp_path / "full.toml")
    assert scene.engine.name == "taichi_mpm" and scene.objects[0].material.name == "jelly"


# -- The README run as a user types it (issue 55) ---------------------------------------------------------------
# Every command line of the README (readme_lines.py finds them) runs from a temporary copy of the clone, in the
# README's order (the quick start's out/donut feeds the lines after it). The default tier cuts every simulation
# to CUT frames (the heavy scenes, listed in HEAVY, run in the slow tier only); the slow tier runs every line
# whole and checks the figures the README states of a whole run. After each line, nothing may lie in the copy's
# root but out/ (the lines' outputs belong under the ignored out/).
import json
import subprocess

import readme_lines as rl
from gasp_testing import needs_package

CUT = 1
#: Lines whose scenes take minutes even cut (a 272,562-point guitar, the kitchen, two engines): slow tier only.
HEAVY = ("guitar_sand.toml", "kitchen_spinach.toml", "donut_on_guitar.toml", "gasp compare")
#: The page the README donut exports must stay under this (issue 55), and its stated size within PAGE_TOL.
PAGE_LIMIT, PAGE_TOL = 5.0e6, 0.05


def stated(pattern: str) -> re.Match:
    m = re.search(pattern, re.sub(r"\s+", " ", readme()))   # a stated line may wrap in the README
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


#: What each line must show beyond exit code 0 (keyed by a piece of the step), and the package it needs.
CHECKS = {
    "gasp simulate examples/donut_jelly.toml -o out/donut --resume": (check_resume, None),
    "gasp simulate examples/donut_jelly.toml -o out/donut": (check_quick_start, "gasp_taichi_mpm"),
    "gasp info examples/data/donut_v3dg.ply --rho 300": (lambda r, c, f: ("mass_kg" in r.stdout) or pytest.fail(r.stdout),
                                                          None),
    "--engine warp_mpm -o out/donut_warp": (exists("out/donut_warp/run.json"), "gasp_warp_mpm"),
    "guitar_sand.toml -o out/guitar": (exists("out/guitar/run.json"), None),
    "kitchen_spinach.toml -o out/kitchen": (exists("out/kitchen/run.json"), None),
    "donut_on_guitar.toml -o out/on_guitar": (exists("out/on_guitar/run.json"), None),
    "donut_mesh.toml -o out/donut_mesh": (exists("out/donut_mesh/run.json"), "trimesh"),
    "donut_wood.toml -o out/wood": (exists("out/wood/run.json"), None),
    "--quality draft -o out/draft": (exists("out/draft/run.json"), None),
    "--format spz -o out/donut_spz": (exists("out/donut_spz/donut_v3dg/frame_0000.spz"), "gsply"),
    "gasp export out/donut --format usd": (exists("out/donut.usdc"), "pxr"),
    "gasp simulate examples/donut_jelly.toml -o out/donut_json --json": (check_json, None),
    "gasp compare": (exists("out/compare/report.md"), "gasp_warp_mpm"),
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


def run_step(step: str, copy, frames):
    key, (check, package) = check_for(step)
    if package:
        needs_package(package)
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
