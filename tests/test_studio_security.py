"""``gasp studio`` lets in only its user and answers every value in one line (issue 41, items 2 and 3).

Real clients on loopback (``websockets``, ``http.client``, a raw socket) talk to a studio serving the donut: without
the token, with a wrong one, from another Origin or another Host they are refused with HTTP 403 and change
nothing; with the token they connect. Values the page's widgets would never send (``"nan"`` frames, ``"abc"`` in a
number field, an unknown material, an unknown property, a fractional frame count, a save path outside the studio's
folder) each get one line in the page, no traceback in the server's output, and no run or file.
"""
import asyncio
import http.client
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

viser = pytest.importorskip("viser", reason='the view extra is not installed: python -m pip install -e ".[view]"')
pytest.importorskip("tomli_w", reason='the view extra is not installed: python -m pip install -e ".[view]"')
import msgspec  # noqa: E402  (viser's own dependency)
from websockets.asyncio.client import connect  # noqa: E402
from websockets.exceptions import InvalidStatus  # noqa: E402

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"
PROTOCOL = f"viser-v{viser.__version__}"
CAMERA = {"type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, -1.0, 0.5], "fov": 1.0,
          "near": 0.01, "far": 100.0, "image_height": 480, "image_width": 640, "look_at": [0.0, 0.0, 0.0],
          "up_direction": [0.0, 0.0, 1.0]}


@pytest.fixture
def studio(tmp_path):
    from gasp_core.studio.app import Studio
    st = Studio(DONUT, tmp_path / "studio", port=0, warm=False)   # no warm-up files or lines beside the checks
    st.form.material.value = "jelly"
    yield st
    st.stop()


def _files(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _handle(st, label: str):
    return next(h for h in st.server.gui._gui_input_handle_from_uuid.values() if h.label == label)


async def _open(url, origin=None, headers=None):
    """``open`` or ``403 <the server's line>``."""
    try:
        async with connect(url, subprotocols=[PROTOCOL], origin=origin, additional_headers=headers,
                           open_timeout=10, max_size=None):
            return "open"
    except InvalidStatus as e:
        return f"{e.response.status_code} {bytes(e.response.body).decode().strip()}"


def _raw(port, path, *headers):
    """A websocket handshake written by hand (its own Host lines): ``<status> <the server's line>``."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall("\r\n".join([f"GET {path} HTTP/1.1", *headers, "Upgrade: websocket", "Connection: Upgrade",
                                "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==", "Sec-WebSocket-Version: 13",
                                f"Sec-WebSocket-Protocol: {PROTOCOL}", "", ""]).encode())
        reply = b""
        while chunk := s.recv(4096):
            reply += chunk
    head, _, body = reply.decode().partition("\r\n\r\n")
    return f"{head.split()[1]} {body.strip()}"


def _send(st, messages, said: int):
    """Send ``messages`` (dicts) over a websocket holding the token; wait until the page said ``said`` more lines."""
    before = st.n_said

    async def go():
        async with connect(f"ws://127.0.0.1:{st.port}/?token={st.gate.token}", subprotocols=[PROTOCOL],
                           open_timeout=10, max_size=None) as ws:
            await ws.send(msgspec.msgpack.encode(CAMERA))         # a page is a client once its camera speaks
            for m in messages:
                await ws.send(m if isinstance(m, bytes) else msgspec.msgpack.encode(m))
            t0 = time.time()
            while st.n_said < before + said and time.time() - t0 < 20:
                await asyncio.sleep(0.05)
            await asyncio.sleep(0.2)
    asyncio.run(go())
    return st.message_log[: st.n_said - before]


def _update(st, label, updates):
    return {"type": "GuiUpdateMessage", "uuid": _handle(st, label)._impl.uuid, "updates": updates}


def _no_traceback(capfd, caplog):
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err, out + err
    assert not [r for r in caplog.records if r.exc_info], [r.getMessage() for r in caplog.records]
    return out + err


def test_a_websocket_without_the_token_or_from_another_origin_is_refused_and_changes_nothing(studio, tmp_path):
    port, token = studio.port, studio.gate.token
    base = f"ws://127.0.0.1:{port}"
    before = (_files(tmp_path), studio.form.frames.value, list(studio.message_log))
    refused = {
        "no token": asyncio.run(_open(base)),
        "wrong token": asyncio.run(_open(f"{base}/?token=x{token}")),
        "another origin": asyncio.run(_open(f"{base}/?token={token}", origin="http://evil.example")),
        "another host": _raw(port, f"/?token={token}", f"Host: evil.example:{port}"),
        "two hosts": _raw(port, f"/?token={token}", f"Host: 127.0.0.1:{port}", f"Host: evil.example:{port}"),
        "cookie of another port": asyncio.run(_open(base, headers={"Cookie": f"gasp_studio_{port + 1}={token}"})),
    }
    for why, answer in refused.items():
        assert answer.startswith("403 gasp studio: refused: "), (why, answer)
        assert "\n" not in answer
    assert "no token" in refused["no token"] and "Origin 'http://evil.example'" in refused["another origin"]
    assert "Host 'evil.example:" in refused["another host"]
    assert not studio.server.get_clients()
    assert (_files(tmp_path), studio.form.frames.value, list(studio.message_log)) == before
    # with the token: from no page (a script), from the studio's own page, or with the page's cookie
    assert asyncio.run(_open(f"{base}/?token={token}")) == "open"
    assert asyncio.run(_open(f"{base}/?token={token}", origin=f"http://127.0.0.1:{port}")) == "open"
    assert asyncio.run(_open(base, origin=f"http://127.0.0.1:{port}",
                             headers={"Cookie": f"gasp_studio_{port}={token}"})) == "open"


def test_the_page_needs_the_token_and_sets_the_cookie_its_websocket_carries(studio):
    c = http.client.HTTPConnection("127.0.0.1", studio.port, timeout=10)
    c.request("GET", "/")
    r = c.getresponse()
    assert r.status == 403 and r.read().decode().startswith("gasp studio: refused: no token")
    c.request("GET", studio.url[len(f"http://127.0.0.1:{studio.port}"):])
    r = c.getresponse()
    body = r.read()
    assert r.status == 200 and b"<html" in body.lower()[:200] or len(body) > 10000
    cookie = r.getheader("Set-Cookie")
    assert cookie.startswith(f"gasp_studio_{studio.port}={studio.gate.token};") and "HttpOnly" in cookie
    assert re.fullmatch(r"http://127\.0\.0\.1:\d+/\?token=[\w-]{40,}", studio.url)


def test_values_the_page_never_sends_get_one_line_and_change_nothing(studio, tmp_path, capfd, caplog):
    """nan frames, "abc" in a number field, an unknown material, an unknown property, a fractional frame count,
    a value for a disabled field: one line each naming the field, the value kept, no run, no file."""
    capfd.readouterr()
    form = studio.form
    studio.click(*_down_onto(studio))          # something selected: Run would start if a value got through
    before = (_files(tmp_path), form.frames.value, form.values["E"].value, form.material.value)
    bad = [(_update(studio, "Frames", {"value": "nan"}), r"^Frames: expected a whole number, got 'nan'"),
           (_update(studio, "Frames", {"value": float("nan")}), r"^Frames: expected a finite number"),
           (_update(studio, "E (Pa)", {"value": "abc"}), r"^E \(Pa\): expected a number, got 'abc'"),
           (_update(studio, "Material", {"value": "bogus"}), r"^Material: expected one of .*jelly.*, got 'bogus'"),
           (_update(studio, "Frames", {"bogus": 1}), r"^Frames: the page may set only its value, not \['bogus'\]"),
           (_update(studio, "Frames", {"value": 2.5}), r"^Frames: expected a whole number, got 2\.5"),
           (_update(studio, "Scale (m per file unit)", {"value": 1e400}), r"^Scale .*: expected a finite number"),
           (_update(studio, "Frame", {"value": 0}), r"^Frame: this field is fixed here \(disabled")]
    for message, expected in bad:
        said = _send(studio, [message], said=1)
        assert len(said) == 1 and re.match(expected, said[0]) and "\n" not in said[0], (expected, said)
    assert (_files(tmp_path), form.frames.value, form.values["E"].value, form.material.value) == before
    assert studio.stream is None
    _no_traceback(capfd, caplog)
    # a good value from the page is applied, typed: the studio's run would use exactly it
    _send(studio, [_update(studio, "Frames", {"value": 3})], said=0)
    assert form.frames.value == 3 and type(form.frames.value) is int


def test_save_writes_only_inside_the_studio_folder_and_replaces_only_its_own_files(studio, tmp_path, capfd, caplog):
    capfd.readouterr()
    work = tmp_path / "studio"
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (work / "out").symlink_to(outside)
    studio.click(*_down_onto(studio))
    save = _update(studio, "Save scene", {"value": True})
    for name, expected in ((str(tmp_path / "evil.toml"), "is outside"), ("../evil.toml", "'..' is not allowed"),
                           ("out/evil.toml", "is outside"), ("/etc/evil.toml", "is outside"),
                           ("evil.sh", "ending in .toml")):
        said = _send(studio, [_update(studio, "Scene file", {"value": name}), save], said=1)
        assert len(said) == 1 and said[0].startswith("Scene file: ") and expected in said[0], (name, said)
    assert _files(outside) == [] and not (tmp_path / "evil.toml").exists()
    # inside: written; again: refused; Overwrite replaces the studio's own file, never one it did not write
    said = _send(studio, [_update(studio, "Scene file", {"value": "keep.toml"}), save], said=1)
    assert said[0].startswith(f"saved {work.resolve() / 'keep.toml'}") and (work / "keep.select0.npy").is_file()
    assert "exists; choose another name" in _send(studio, [save], said=1)[0]
    tick = _update(studio, "Overwrite", {"value": True})
    assert _send(studio, [tick, save], said=1)[0].startswith("saved ")
    (work / "theirs.toml").write_text("# the user's own\n")
    said = _send(studio, [_update(studio, "Scene file", {"value": "theirs.toml"}), save], said=1)
    assert "was not written by this studio session" in said[0]
    assert (work / "theirs.toml").read_text() == "# the user's own\n"
    _no_traceback(capfd, caplog)


def test_malformed_requests_and_messages_cost_one_line_at_most_and_no_traceback(studio, capfd, caplog):
    capfd.readouterr()
    port = studio.port
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:   # a request line without CRLF
        s.sendall(b"GET / HTTP/1.1")
        s.shutdown(socket.SHUT_WR)
        s.recv(100)
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:   # not HTTP at all
        s.sendall(b"\x00\xff garbage\r\n\r\n")
        s.recv(100)
    for raw in (b"\x93garbage", msgspec.msgpack.encode({"type": "NoSuchMessage", "x": 1}),
                msgspec.msgpack.encode({"type": "GuiUpdateMessage", "uuid": [1], "updates": {}})):
        try:
            _send(studio, [raw], said=0)
        except Exception:  # noqa: BLE001 (the server may close the connection: that is its answer)
            pass
    time.sleep(0.5)
    out = _no_traceback(capfd, caplog)
    assert len([line for line in out.splitlines() if line.strip()]) <= 5, out
    # and it keeps serving its user
    assert asyncio.run(_open(f"ws://127.0.0.1:{port}/?token={studio.gate.token}")) == "open"


def test_host_beyond_loopback_says_what_it_exposes():
    from gasp_core.studio.guard import Gate, exposure_line, is_loopback
    assert exposure_line("127.0.0.1", "/w") is None and exposure_line("localhost", "/w") is None
    line = exposure_line("0.0.0.0", "/w")
    assert "\n" not in line and "beyond this machine" in line and "token" in line and "/w" in line
    assert is_loopback("::1") and not is_loopback("192.168.1.5")
    assert Gate("0.0.0.0", token="T").url(8080) == "http://127.0.0.1:8080/?token=T"


def test_gasp_studio_prints_its_url_with_the_token_and_refuses_a_client_without_it(tmp_path):
    p = subprocess.Popen([sys.executable, "-m", "gasp_core", "studio", str(DONUT), "--port", "0", "--workdir",
                          str(tmp_path / "w")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        line = p.stdout.readline()
        m = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=([\w-]+)", line)
        assert m, line + p.stderr.read() if p.poll() is not None else line
        port, token = m.group(1), m.group(2)
        assert asyncio.run(_open(f"ws://127.0.0.1:{port}")).startswith("403 gasp studio: refused: no token")
        assert asyncio.run(_open(f"ws://127.0.0.1:{port}/?token={token}", origin="http://evil.example")
                           ).startswith("403 gasp studio: refused: Origin")
        assert asyncio.run(_open(f"ws://127.0.0.1:{port}/?token={token}")) == "open"
    finally:
        p.terminate()
        _, err = p.communicate(timeout=30)
    assert "Traceback" not in err, err


def _down_onto(st):
    """A ray straight down onto the donut's ring."""
    p = st.scene.pieces[0]
    c = np.median(p.means, axis=0)
    r = np.percentile(np.hypot(*(p.means[:, :2] - c[:2]).T), 50)
    return (c[0] + r, c[1], 1.0), (0.0, 0.0, -1.0)
