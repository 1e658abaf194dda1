"""Logs of the websocket server under viser (``gasp view``, ``gasp studio``): a client's bad request as one line.

A browser, a scanner or a half-written HTTP request reaches the server viser runs (``websockets``); its default
log prints a traceback per such connection. :class:`QuietLogs` turns each into one line, or none.
"""
from __future__ import annotations

import logging


class QuietLogs(logging.Filter):
    """On the ``websockets.server`` logger: a connection that failed its handshake or sent what viser cannot read
    (garbage MessagePack, an unknown message type) gives one line, without its traceback; a connection closed
    before it said anything (browsers open spare ones) gives none. ``who`` starts the line (``gasp studio``,
    ``gasp view``)."""

    LOGGER = "websockets.server"

    def __init__(self, who: str = "gasp studio"):
        super().__init__()
        self.who = who

    def filter(self, record: logging.LogRecord) -> bool:
        if record.exc_info is None:
            return record.levelno < logging.WARNING or record.getMessage() not in (
                "opening handshake failed", "connection rejected (200 OK)")
        exc = record.exc_info[1]
        record.exc_info, record.exc_text, record.stack_info = None, None, None
        cause = exc.__cause__ or exc
        if isinstance(cause, (EOFError, ConnectionError, TimeoutError)):
            return False
        what = "a request that is not HTTP" if "handshake" in record.getMessage() else "a message it cannot read"
        record.msg, record.args = f"{self.who}: closed a connection that sent {what} ({type(cause).__name__})", ()
        return True

    def __enter__(self):
        logging.getLogger(self.LOGGER).addFilter(self)
        return self

    def __exit__(self, *exc):
        logging.getLogger(self.LOGGER).removeFilter(self)
