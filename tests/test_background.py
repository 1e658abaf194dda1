"""The frame loop's background writer (gasp_core.run.background): order, errors, and no job left half done."""
import threading
import time

import pytest

from gasp_core.run.background import Background


def test_jobs_run_in_order_on_one_other_thread():
    seen = []
    with Background() as bg:
        for i in range(5):
            bg.submit(lambda i=i: (time.sleep(0.01 * (5 - i)), seen.append((i, threading.current_thread().name))))
    assert [i for i, _ in seen] == list(range(5))
    assert {name for _, name in seen} != {threading.current_thread().name}


def test_a_job_error_comes_back_at_the_next_submit_or_at_the_end():
    def fail():
        raise OSError("disk full")
    with pytest.raises(OSError, match="disk full"):
        with Background() as bg:
            bg.submit(fail)
            bg.submit(lambda: None)
    with pytest.raises(OSError, match="disk full"):
        with Background() as bg:
            bg.submit(fail)


def test_an_error_in_the_loop_waits_for_the_job_in_flight(tmp_path):
    """The caller's error goes through, after the frame being written is complete."""
    out = tmp_path / "frame.txt"

    def slow_write():
        time.sleep(0.3)
        out.write_text("done")
    with pytest.raises(RuntimeError, match="engine blew up"):
        with Background() as bg:
            bg.submit(slow_write)
            raise RuntimeError("engine blew up")
    assert out.read_text() == "done"
