"""See the result: render a run's Gaussian frames to video, PNGs or a strip, or play them in a browser.

Renderers are plugins, found through the ``gasp_renderers`` hook (:mod:`gasp_core.render.registry`). The
built-in CPU renderers live in :mod:`gasp_core.render.builtin`: ``cpu`` (a numba kernel, needs the
``render`` extra) and ``numpy`` (pure NumPy, always available, much slower).
"""
