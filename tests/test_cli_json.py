"""One reporter (issue 33): ``gasp simulate --json`` prints one JSON object per line on stdout and nothing else;
errors keep their exit status and their one ``gasp: error:`` line on stderr, plus one error event on stdout."""
import json
import subprocess
import sys
from pathlib import Path

import pytest
from gasp_testing import scene_text

from gasp_core.cli.main import build_parser, main
from gasp_core.run.report import ConsoleReporter, JsonLinesReporter, Reporter
from gasp_core.run.request import SimulateRequest, option_fields

ENGINE = "warp_mpm"
N_FRAMES = 2


def gasp(*argv):
    return subprocess.run([sys.executable, "-m", "gasp_core.cli.main", *map(str, argv)], capture_output=True,
                          text=True, timeout=600)


def small_scene(tmp_path, donut_small, **kw) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(scene_text(donut_small, n_frames=N_FRAMES, n_grid=16, engine=ENGINE, engine_options="{ }", **kw))
    return p


def check_stream(stdout: str, n_frames: int) -> list[dict]:
    """Every stdout line is one JSON object with an ``event``; one frame event per frame 0..n_frames in order,
    with its timings; the last event is the result, naming a run.json that exists and agrees."""
    events = [json.loads(line) for line in stdout.splitlines()]
    assert events and all(isinstance(e, dict) and "event" in e for e in events), stdout
    frames = [e for e in events if e["event"] == "frame"]
    assert [e["frame"] for e in frames] == list(range(n_frames + 1)), frames
    assert all(e["wall_s"] >= 0.0 for e in frames)
    assert all(e["sim_s"] > 0.0 and e["n_substeps"] >= 1 for e in frames[1:]), frames
    result = events[-1]
    assert result["event"] == "result", events
    run = json.loads(Path(result["run_json"]).read_text())
    assert Path(result["run_json"]).parent == Path(result["output"])
    assert len(run["frames"]) == n_frames + 1 == result["n_frames"]
    assert result["n_substeps"] == run["engine_stats"]["n_substeps"] == frames[-1]["n_substeps"]
    return events


def test_simulate_json_is_one_event_per_line(tmp_path, donut_small):
    """The command as a script runs it: a separate process, stdout parsed line by line (library banners,
    if any, went to stderr)."""
    pytest.importorskip(f"gasp_{ENGINE}")
    # a shell (fill = false) at n_grid 16 is 7.9 cells across its width: the resolution advice, a warning
    r = gasp("simulate", small_scene(tmp_path, donut_small, extra_object="fill = false"), "-o", tmp_path / "out",
             "--json")
    assert r.returncode == 0, r.stderr
    events = check_stream(r.stdout, N_FRAMES)
    assert Path(events[-1]["output"]) == (tmp_path / "out").resolve()
    assert [e["event"] for e in events if e["event"] not in ("frame", "warning")] == ["start", "result"]
    assert events[[e["event"] for e in events].index("start")]["engine"] == ENGINE
    # the warnings are events, and also the console's lines on stderr
    said = [e["message"] for e in events if e["event"] == "warning"]
    assert said and [f"gasp: warning: {m}" for m in said] == r.stderr.splitlines(), r.stderr


def test_the_frame_check_catches_a_reporter_that_drops_a_frame(tmp_path, donut_small, capsys, monkeypatch):
    """The same check on an in-process run passes, and fails once the JSON backend loses frame 1's event."""
    pytest.importorskip(f"gasp_{ENGINE}")
    scene = small_scene(tmp_path, donut_small)
    assert main(["simulate", str(scene), "-o", str(tmp_path / "a"), "--json"]) == 0
    check_stream(capsys.readouterr().out, N_FRAMES)
    real = JsonLinesReporter.frame
    monkeypatch.setattr(JsonLinesReporter, "frame", lambda self, frame, *a: None if frame == 1 else real(self, frame, *a))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "b"), "--json"]) == 0
    with pytest.raises(AssertionError, match=r"assert \[0, 2\] == \[0, 1, 2\]"):
        check_stream(capsys.readouterr().out, N_FRAMES)


def test_bad_scene_under_json_is_exit_2_one_event_and_one_line(tmp_path, donut_small):
    r = gasp("simulate", small_scene(tmp_path, donut_small, material='name = "jelly"\nE = -5.0\nnu = 0.3\nrho = 300.0'),
             "-o", tmp_path / "out", "--json")
    assert r.returncode == 2
    lines = r.stdout.splitlines()
    assert len(lines) == 1, r.stdout
    event = json.loads(lines[0])
    assert event["event"] == "error" and event["status"] == 2 and "material.E" in event["message"]
    assert r.stderr.splitlines() == [f"gasp: error: {event['message']}"], r.stderr
    assert not (tmp_path / "out").exists()


def test_divergence_under_json_is_exit_3_with_its_event(tmp_path, donut_small, capsys):
    """No ground and one substep a frame (as tests/test_cli.py): the falling donut moves more than a cell a step;
    status 3, said both ways (a point that leaves slower drops out and is counted: tests/test_left_domain.py)."""
    pytest.importorskip(f"gasp_{ENGINE}")
    text = scene_text(donut_small, ground=False, n_frames=20, n_grid=16, engine=ENGINE,
                      engine_options="{ n_substeps = 1 }")
    (tmp_path / "s.toml").write_text(text)
    assert main(["simulate", str(tmp_path / "s.toml"), "-o", str(tmp_path / "out"), "--json"]) == 3
    out, err = capsys.readouterr()
    events = [json.loads(line) for line in out.splitlines()]
    assert events[-1]["event"] == "error" and events[-1]["status"] == 3 and "time step" in events[-1]["message"]
    assert [e for e in events if e["event"] == "frame"], "the frames before the blow-up are reported"
    errors = [line for line in err.splitlines() if line.startswith("gasp: error:")]
    assert errors == [f"gasp: error: {events[-1]['message']}"]


def test_what_else_is_written_to_stdout_under_json_goes_to_stderr():
    """Python's print and C-level writes on fd 1 (an engine's banner) while the command runs land on stderr."""
    code = ("import os, types\n"
            "from gasp_core.cli.simulate import reporter_for\n"
            "with reporter_for(types.SimpleNamespace(command='simulate', json=True)) as r:\n"
            "    print('python chatter'); os.write(1, b'C chatter\\n'); r.warning('w')\n"
            "print('after')\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines() == ['{"event": "warning", "message": "w"}', "after"]
    assert p.stderr.splitlines() == ["python chatter", "C chatter", "gasp: warning: w"]


def test_console_backend_says_what_the_command_always_said(capsys):
    c = ConsoleReporter(progress=False)
    c.start("engine", 2)
    c.frame(1, 0.1, 0.1, 3)
    c.warning("something to know")
    c.result("wrote 3 frames", run_json="x/run.json")
    c.error("error: a bad value", 2)
    out, err = capsys.readouterr()
    assert out == "wrote 3 frames\n"
    assert err == "gasp: warning: something to know\ngasp: error: a bad value\n"


def test_json_backend_writes_null_for_a_float_that_is_not_finite(capsys):
    import io
    s = io.StringIO()
    JsonLinesReporter(s).frame(3, float("nan"), float("inf"))
    assert json.loads(s.getvalue()) == {"event": "frame", "frame": 3, "wall_s": None, "sim_s": None}
    r = Reporter()
    r.warning("kept")
    assert r.events == [{"event": "warning", "message": "kept"}]


def test_simulate_options_are_the_request_fields():
    """Every SimulateRequest field is a ``gasp simulate`` option with its help, parsed back to the same request."""
    sub = build_parser()._subparsers._group_actions[0].choices["simulate"]
    actions = {a.dest: a for a in sub._actions}
    for f in option_fields():
        assert f.name in actions and actions[f.name].help == f.metadata["help"], f.name
        assert list(actions[f.name].option_strings) == list(f.metadata["flags"])
    args = build_parser().parse_args(["simulate", "s.toml", "--frames", "3", "--format", "spz", "--engine", "e",
                                      "--overwrite", "-q"])
    from gasp_core.cli.simulate import request_from
    assert request_from(args) == SimulateRequest(n_frames=3, fmt="spz", engine="e", overwrite=True, quiet=True)
    assert request_from(build_parser().parse_args(["simulate", "s.toml"])) == SimulateRequest()
    with pytest.raises(TypeError):
        SimulateRequest(True)                                     # keyword-only


def test_simulate_scene_refuses_an_option_it_does_not_have(tmp_path):
    from gasp_core.run.pipeline import simulate_scene
    with pytest.raises(TypeError, match="progress"):
        simulate_scene(None, tmp_path / "out", progress=False)
