"""What the studio lets in: its user only, and only values its page could send.

* **the door** (:class:`Gate`): every HTTP request and websocket handshake needs the studio's token (a random
  ``secrets.token_urlsafe`` printed in the URL, as Jupyter does), from the URL's query (``?token=``) or from the
  cookie the page receives with it; a request that carries an ``Origin`` must come from the studio's own page
  (``http://`` + the ``Host`` it was asked for), and on a loopback address the ``Host`` must name this machine
  (no DNS rebinding). A refusal is HTTP 403 with one line, before viser sees the request. viser (1.1) offers no
  hook on its handshake, but it serves through ``websockets.asyncio.server.serve`` with a ``process_request``
  of its own; :func:`gated_serve` wraps that one call while the studio's server starts, and the studio refuses
  to start when the wrap did not take (:class:`~gasp_core.errors.SceneError`, one line).
* **the values** (:func:`check_update`): a GUI update from the page is parsed against the widget it names
  before viser casts it (viser's ``int("nan")``, ``float("abc")``, its ``assert`` on an unknown property, its
  silent ``int(2.5)``): numbers finite, whole where the widget counts, a dropdown's value one of its options,
  a checkbox a bool, no update to a disabled widget. A refused value gets one line in the page and changes
  nothing.
* **the files** (:func:`inside`): a path from the page is a file inside the studio's folder (or the folder
  named by ``--save-dir``), never ``..``, never through a symlink that leads out.
* **the logs** (:class:`gasp_core.render.quiet_logs.QuietLogs`): a malformed HTTP request or websocket message costs its connection and at
  most one line in the server's output, never a traceback.
"""
from __future__ import annotations

import contextlib
import http
import ipaddress
import math
import secrets
import threading
from http.cookies import CookieError, SimpleCookie
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from gasp_core.errors import SceneError
from gasp_core.render.quiet_logs import QuietLogs  # noqa: F401  (the studio's, beside its other guards)

def one_line(text: str) -> str:
    """``text`` on one line (a message from a library may span several)."""
    return " ".join(text.split())


#: Longest text a text field of the page may send (a path, a page name).
MAX_TEXT = 1024
_SERVE_LOCK = threading.Lock()


def is_loopback(host: str) -> bool:
    """True for an address or name of this machine only (``127.0.0.0/8``, ``::1``, ``localhost``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def exposure_line(host: str, folders: str) -> str | None:
    """One line saying what ``--host`` exposes when it is not loopback (None on loopback); ``folders``: where the
    studio writes."""
    if is_loopback(host):
        return None
    return (f"gasp studio: --host {host} listens beyond this machine: whoever reaches this port and holds the "
            f"URL's token can see the scene, run simulations and write files in {folders}")


class Gate:
    """The studio's token and the checks of each request (module notes).

    Parameters
    ----------
    host : str
        The address the server listens on (``--host``).
    token : str, optional
        Default: a new ``secrets.token_urlsafe(32)``.

    Attributes
    ----------
    installed : bool
        True once the check wraps a server's ``process_request`` (:func:`gated_serve`).
    """

    def __init__(self, host: str, token: str | None = None):
        self.host = host
        self.token = token or secrets.token_urlsafe(32)
        self.loopback = is_loopback(host)
        self.installed = False

    @staticmethod
    def cookie_name(port: int) -> str:
        """Cookies are shared by every port of a host, so the cookie names its port."""
        return f"gasp_studio_{port}"

    def url(self, port: int) -> str:
        """The URL to open: ``http://HOST:PORT/?token=...`` (a wildcard host printed as 127.0.0.1)."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "", "::") else self.host
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{port}/?token={self.token}"

    def _token_of(self, request, port: int) -> tuple[str | None, str]:
        """The token the request holds and where it came from (``query``, ``cookie``, or ``""``)."""
        given = parse_qs(urlsplit(request.path).query).get("token")
        if given:
            return given[0], "query"
        try:
            jar = SimpleCookie(request.headers.get("Cookie", ""))
        except CookieError:
            return None, ""
        morsel = jar.get(self.cookie_name(port))
        return (morsel.value, "cookie") if morsel is not None else (None, "")

    def refusal(self, request, port: int) -> str | None:
        """Why ``request`` (a :class:`websockets.http11.Request` reaching ``port``) is refused: one line, or None."""
        h = request.headers
        for name in ("Host", "Origin", "Cookie"):
            if len(h.get_all(name)) > 1:
                return f"gasp studio: refused: the request has {len(h.get_all(name))} {name} headers; expected one"
        host_header = h.get("Host", "")
        if self.loopback:
            try:
                parts = urlsplit("//" + host_header)
                name, asked_port = parts.hostname, parts.port
            except ValueError:
                name, asked_port = None, None
            if name is None or not is_loopback(name) or asked_port not in (None, port):
                return (f"gasp studio: refused: Host {host_header!r} is not this machine (the studio listens on "
                        f"{self.host} port {port})")
        origin = h.get("Origin")
        if origin is not None and origin.lower() not in (f"http://{host_header}".lower(),
                                                         f"https://{host_header}".lower()):
            return (f"gasp studio: refused: Origin {origin!r} is not the studio's own page "
                    f"(http://{host_header}); only the page gasp studio serves may connect")
        token, _ = self._token_of(request, port)
        if token is None or not secrets.compare_digest(token.encode(), self.token.encode()):
            return ("gasp studio: refused: " + ("no token" if token is None else "a wrong token") +
                    "; open the URL gasp studio printed (http://HOST:PORT/?token=...)")
        return None

    def wrap(self, inner):
        """``inner`` (viser's ``process_request``) behind the checks: HTTP 403 with one line when refused; the page
        fetched with the token in its URL sets the cookie its websocket then carries."""
        def process_request(connection, request):
            port = connection.local_address[1]
            why = self.refusal(request, port)
            if why is not None:
                return connection.respond(http.HTTPStatus.FORBIDDEN, why + "\n")
            response = inner(connection, request) if inner is not None else None
            if response is not None:
                if self._token_of(request, port)[1] == "query":
                    response.headers["Set-Cookie"] = (f"{self.cookie_name(port)}={self.token}; Path=/; HttpOnly; "
                                                      "SameSite=Strict")
                response.headers["Referrer-Policy"] = "no-referrer"
                response.headers["Cache-Control"] = "no-store"
            return response
        self.installed = True
        return process_request


@contextlib.contextmanager
def gated_serve(gate: Gate):
    """While the block runs, every ``websockets.asyncio.server.serve`` call (viser's, made as its server starts)
    gets ``gate``'s check in front of its ``process_request``; the library is restored after.

    viser's ``ViserServer`` returns only once its server is bound, so a server started inside the block is
    gated from its first connection. Studios starting at once in one process take turns.
    """
    import websockets.asyncio.server as wss
    original = wss.serve

    class serve(original):                                    # noqa: N801 (the library's name)
        def __init__(self, handler, *args, process_request=None, **kwargs):
            super().__init__(handler, *args, process_request=gate.wrap(process_request), **kwargs)

    with _SERVE_LOCK:
        wss.serve = serve
        try:
            yield gate
        finally:
            wss.serve = original


# -- values from the page -----------------------------------------------------------------------------------
def _number(label: str, value, whole: bool):
    """A finite number (a whole one if ``whole``) from the page, else a one-line :class:`SceneError`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{label}: expected a {'whole ' if whole else ''}number, got {value!r}; nothing changed")
    if not math.isfinite(value):
        raise SceneError(f"{label}: expected a finite number, got {value!r}; nothing changed")
    if whole:
        if not float(value).is_integer():
            raise SceneError(f"{label}: expected a whole number, got {value!r}; nothing changed")
        return int(value)
    return float(value)


def check_update(handle, updates) -> dict:
    """The page's ``updates`` to GUI input ``handle`` (a viser handle), parsed by the widget's own type.

    Returns
    -------
    dict
        ``{"value": parsed}``: what viser may apply (its cast is then the identity).

    Raises
    ------
    SceneError
        One line naming the widget and what was expected; nothing was applied.
    """
    import viser
    label = str(getattr(handle, "label", "") or "a field of the page")
    if not isinstance(updates, dict) or set(updates) != {"value"}:
        names = sorted(map(str, updates)) if isinstance(updates, dict) else updates
        raise SceneError(f"{label}: the page may set only its value, not {names!r}; nothing changed")
    if getattr(handle, "disabled", False):
        raise SceneError(f"{label}: this field is fixed here (disabled in the page); nothing changed")
    value, current = updates["value"], handle.value
    if isinstance(handle, viser.GuiButtonHandle):
        if value is not True:
            raise SceneError(f"{label}: a button sends true, got {value!r}; nothing done")
        return {"value": True}
    if isinstance(handle, viser.GuiCheckboxHandle):
        if not isinstance(value, bool):
            raise SceneError(f"{label}: expected true or false, got {value!r}; nothing changed")
        return {"value": value}
    if isinstance(handle, viser.GuiDropdownHandle):
        if not isinstance(value, str) or value not in handle.options:
            raise SceneError(f"{label}: expected one of {', '.join(handle.options)}, got {value!r}; nothing changed")
        return {"value": value}
    if isinstance(handle, viser.GuiSliderHandle):
        v = _number(label, value, whole=isinstance(current, int))
        if not handle.min <= v <= handle.max:
            raise SceneError(f"{label}: expected {handle.min} to {handle.max}, got {value!r}; nothing changed")
        return {"value": v}
    if isinstance(handle, viser.GuiNumberHandle):
        return {"value": _number(label, value, whole=isinstance(current, int))}
    if isinstance(handle, viser.GuiTextHandle):
        if not isinstance(value, str) or len(value) > MAX_TEXT or "\x00" in value:
            shown = repr(value)[:60]
            raise SceneError(f"{label}: expected a text of at most {MAX_TEXT} characters, got {shown}; "
                             "nothing changed")
        return {"value": value}
    raise SceneError(f"{label}: the studio takes no value from this widget; nothing changed")


# -- files --------------------------------------------------------------------------------------------------
def inside(folder: Path, text, field: str, suffix: str) -> Path:
    """The file ``text`` (from the page) names inside ``folder``: a name relative to it, or an absolute path
    inside it; resolved, so a symlink that leads out is refused like ``..``.

    Raises
    ------
    SceneError
        One line naming ``field`` and the folder.
    """
    folder = Path(folder).resolve()
    if not isinstance(text, str) or not text.strip() or any(ord(c) < 32 for c in text):
        raise SceneError(f"{field}: expected a file name ending in {suffix} inside {folder}, got {text!r}")
    p = Path(text.strip())
    if ".." in p.parts:
        raise SceneError(f"{field}: {text!r}: '..' is not allowed; the studio writes only inside {folder}")
    target = (p if p.is_absolute() else folder / p).resolve()
    if target == folder or not target.is_relative_to(folder):
        raise SceneError(f"{field}: {text!r} is outside {folder}; the studio writes only there (choose another "
                         "folder with --save-dir)")
    if target.suffix.lower() != suffix:
        raise SceneError(f"{field}: expected a file name ending in {suffix}, got {text!r}")
    return target


# -- logs ---------------------------------------------------------------------------------------------------
def guard_messages(server, say) -> None:
    """Every GUI value from the page through :func:`check_update` before viser casts it (a refusal: one line in the
    page through ``say``, nothing changed); any other message a handler cannot use: one line, no traceback.

    It reaches into viser 1.1's internals (its message classes in ``viser._messages``, its websocket server's
    handler table, its GUI-update handler): a viser upgrade that moves them is caught by
    ``tests/test_studio_security.py``."""
    import viser._messages as viser_messages
    ws, gui = server._websock_server, server.gui
    apply = gui._handle_gui_updates

    async def checked(client_id, message) -> None:
        handle = gui._gui_input_handle_from_uuid.get(message.uuid) if isinstance(message.uuid, str) else None
        if handle is None or handle._impl.removed:
            return
        try:
            message.updates = check_update(handle, message.updates)
        except SceneError as e:
            say(str(e))
            return
        await apply(client_id, message)

    ws.unregister_handler(viser_messages.GuiUpdateMessage, apply)
    ws.register_handler(viser_messages.GuiUpdateMessage, checked)
    for share in (viser_messages.ShareUrlRequest, viser_messages.ShareUrlDisconnect):   # no public tunnel from the page
        if share in ws._incoming_handlers:
            ws.unregister_handler(share)

    def guard(handler) -> None:
        """``handler``'s dispatch of each message (the server's, and each connection's own) made quiet."""
        handle_all = handler._handle_incoming_message

        async def handled(client_id, message) -> None:
            try:
                await handle_all(client_id, message)
            except Exception as e:  # noqa: BLE001
                say(one_line(f"the page sent a {type(message).__name__} the studio cannot use "
                                  f"({type(e).__name__}); ignored"))
        handler._handle_incoming_message = handled

    guard(ws)
    ws.on_client_connect(guard)
