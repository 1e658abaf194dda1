"""Issue 68: nothing warned that a run would take minutes. ``gasp simulate`` says how long a run takes before it
starts, on the line after the bytes it writes: points x substeps x frames at the 2-core CPU's measured rate
(``gasp_core.run.budget.CPU_RATE``, the README donut: 66,071 points x 79 substeps x 36 frames stepped in 111 s,
round 71's quiet fresh clone)."""
import json
import re

import pytest

from gasp_core.cli.main import main
from gasp_core.run.budget import CPU_RATE, start_estimate
from gasp_testing import scene_text


def test_the_readme_donut_is_estimated_at_its_measured_111_s():
    e = start_estimate(66_071, 79, 36)
    assert e["seconds"] == pytest.approx(111.0, abs=2.0) and e["work"] == 66_071 * 79 * 36
    assert e["line"] == ("gasp: the run takes about 1.84 min on a 2-core CPU (66,071 points x 79 substeps x 36 frames "
                         "at 1.7e+06 point-substeps/s, docs/performance.md; an H100 ran 11-40 times faster)"), e["line"]
    assert "load is 5.5 on 2 cores: longer" in start_estimate(66_071, 79, 36, load=(5.5, 2))["line"]
    assert "load" not in start_estimate(66_071, 79, 36, load=(1.5, 2))["line"]
    assert start_estimate(66_071, None, 36) is None            # no step rule before the engine runs: no figure
    assert start_estimate(10, 5, 3)["seconds"] == pytest.approx(150 / CPU_RATE)


def test_gasp_simulate_says_the_time_after_the_bytes(donut_small, write_scene, tmp_path, capsys):
    pytest.importorskip("gasp_taichi_mpm")
    path = write_scene(scene_text(donut_small, n_frames=2))
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    writes = [i for i, line in enumerate(err) if line.startswith("gasp: the run writes about")]
    assert len(writes) == 1, err
    takes = err[writes[0] + 1]
    m = re.match(r"gasp: the run takes about (.+) on a 2-core CPU \(([\d,]+) points x (\d+) substeps x (\d+) frames",
                 takes)
    assert m, takes
    run = json.loads((out / "run.json").read_text())
    points, substeps = int(m.group(2).replace(",", "")), int(m.group(3))
    assert points == run["n_points"], (points, run["n_points"])
    assert substeps == run["engine_stats"]["n_substeps"], (substeps, run["engine_stats"])
    assert int(m.group(4)) == 2


def test_the_json_start_event_carries_the_estimate(donut_small, write_scene, tmp_path, capsys):
    pytest.importorskip("gasp_taichi_mpm")
    path = write_scene(scene_text(donut_small, n_frames=1))
    assert main(["simulate", str(path), "-o", str(tmp_path / "out"), "--json"]) == 0
    events = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
    (start,) = [e for e in events if e["event"] == "start"]
    assert start["estimate_s"] > 0


def test_a_settled_start_adds_its_substeps_to_the_estimate():
    """``settle = true`` runs ``STAGES * STAGE_FRAMES + HOLD_FRAMES`` settle frames before frame 1 (round 84): the
    estimate counts their substeps at the engine's step rule for a settle frame, and says so."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_elastic_slope import CUBE, block_setup

    from gasp_core.seam.plugins import get_engine
    from gasp_core.seam.settle import HOLD_FRAMES, STAGE_FRAMES, STAGES, _still, settle_frame_s, settle_substeps
    plain = start_estimate(66_071, 79, 36)
    settled = start_estimate(66_071, 79, 36, settle_substeps=140 * 20)
    assert settled["seconds"] == pytest.approx(plain["seconds"] + 66_071 * 140 * 20 / CPU_RATE)
    assert "the settle adds 2,800 substeps" in settled["line"] and "settle" not in plain["line"]
    info = get_engine("warp_mpm")
    s = block_setup(30, 0.6, "particle", CUBE, 24)
    n = settle_substeps(info, s)
    assert n == (STAGES * STAGE_FRAMES + HOLD_FRAMES) * info.substeps(_still(s, 1.0, settle_frame_s(s))) > 0
