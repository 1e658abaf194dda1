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


def same_named_test_files(roots: list[Path]) -> dict[str, list[str]]:
    """{basename: [paths]} of the ``test_*.py`` files under ``roots`` whose basename is taken more than once."""
    seen: dict[str, list[str]] = {}
    for top in roots:
        for f in sorted(top.rglob("test_*.py")):
            if "node_modules" not in f.parts:
                seen.setdefault(f.name, []).append(str(f))
    return {n: fs for n, fs in seen.items() if len(fs) > 1}


def test_the_test_command_collects_no_two_test_files_of_one_name():
    """pytest's default import mode (rootdir-relative ``sys.path``, no ``__init__.py``) imports every test file
    under its basename, so two ``test_x.py`` under the testpaths stop the whole run at collection (stop 121's CI:
    ``tests/test_taichi_schedule.py`` beside ``plugins/taichi_mpm/tests/test_taichi_schedule.py``)."""
    import tomllib
    paths = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["testpaths"]
    assert len(list((ROOT / "tests").glob("test_*.py"))) > 100   # the walk has a suite to read
    assert same_named_test_files([ROOT / p for p in paths]) == {}


def test_the_name_check_catches_a_test_file_named_twice(tmp_path):
    for d in ("tests", "plugins/x/tests"):
        (tmp_path / d).mkdir(parents=True)
        (tmp_path / d / "test_a.py").write_text("")
    (tmp_path / "tests" / "test_b.py").write_text("")
    assert list(same_named_test_files([tmp_path / "tests", tmp_path / "plugins"])) == ["test_a.py"]


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



#: The tests the README's browser-tools line (Chromium, splat-transform, Babylon.js) feeds, by tier (issue 68: the
#: README did not say that most of them are slow): node ids, a function standing for all its parameters.
TOOL_TESTS = {
    "default": ["tests/test_export_page.py::test_small_page_plays_every_frame_as_numpy_decodes_it",
                "tests/test_export.py::test_splat_transform_writes_the_same_glb_values_as_gasp",
                "tests/test_formats_splat_transform.py::test_splat_reads_as_in_splat_transform",
                "tests/test_formats_splat_transform.py::test_ksplat_reads_as_in_splat_transform[0]",
                "tests/test_formats_splat_transform.py::test_ksplat_reads_as_in_splat_transform[1]"],
    "slow": ["tests/test_studio_browser.py::test_studio_click_pick_run_watch",
             "tests/test_view.py::test_view_shows_donut_and_slider_changes_picture",
             "tests/test_export_page.py::test_exported_page_shows_donut_moving_from_file",
             "tests/test_live.py::test_the_page_of_a_run_in_progress_says_so_and_shows_the_new_frames",
             "tests/test_export_browser.py::test_babylon_loads_a_gasp_glb_with_every_splat_and_draws_it",
             "tests/test_export_browser.py::test_babylon_plays_a_glb_sequence_one_frame_at_a_time",
             "tests/test_export_browser.py::test_babylon_opens_each_piece_of_a_split_glb_as_its_own_mesh",
             "tests/test_split_pieces.py::test_the_split_glb_of_a_broken_run_opens_in_babylon_as_a_mesh_per_piece",
             "tests/test_formats_splat_transform.py::test_every_file_of_a_run_opens_in_splat_transform[spz]",
             "tests/test_formats_splat_transform.py::test_every_file_of_a_run_opens_in_splat_transform[sog]",
             "tests/test_formats_splat_transform.py::test_every_file_of_a_run_opens_in_splat_transform[compressed_ply]"]}


def test_the_readme_says_which_tests_the_browser_tools_feed():
    """The README's counts of the tests its browser-tools line feeds are the tiers' own: each listed test exists, is
    in the tier said (``tests/slow_tier.txt`` or a ``slow`` mark), and every test that looks for Chromium,
    splat-transform or Babylon.js is listed."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("root_conftest", ROOT / "conftest.py")   # the tiers' own rule
    tiers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tiers)
    _matches, entries = tiers._matches, tiers.slow_entries()
    readme = README.read_text()
    assert (f"They feed {len(TOOL_TESTS['default'])} default tests" in readme
            and f"and {len(TOOL_TESTS['slow'])} slow ones" in readme)
    listed = {n.split("[")[0] for ids in TOOL_TESTS.values() for n in ids}
    for tier, ids in TOOL_TESTS.items():
        for nodeid in ids:
            path, func = nodeid.split("::")
            text = (ROOT / path).read_text()
            assert f"def {func.split('[')[0]}(" in text, nodeid
            block = text.split(f"def {func.split('[')[0]}(")[0].rsplit("\n\n\n", 1)[-1]
            slow = any(_matches(nodeid, e) for e in entries) or "@pytest.mark.slow" in block
            assert slow == (tier == "slow"), (nodeid, tier)
    needs = re.compile(r"chromium|CHROMIUM|splat.transform|babylon|\bST\b")
    for f in ["test_export_page.py", "test_export.py", "test_formats_splat_transform.py", "test_studio_browser.py",
              "test_view.py", "test_live.py", "test_export_browser.py", "test_split_pieces.py"]:
        text = (ROOT / "tests" / f).read_text()
        module_wide = re.search(r"pytest\.skip\([^)]*(chromium|splat|babylon)[^)]*allow_module_level", text,
                                re.I | re.S)
        for m in re.finditer(r"^(?:@[^\n]*\n)*def (test_\w+)\((.*?)^(?=def |@|\Z)", text, re.M | re.S):
            if module_wide or needs.search(m.group(0)):
                assert f"tests/{f}::{m.group(1)}" in listed, f"tests/{f}::{m.group(1)} needs a browser tool"
