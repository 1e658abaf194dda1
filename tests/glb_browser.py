"""A GLB opened by a real glTF reader in headless Chromium: Babylon.js (npm ``babylonjs`` + ``babylonjs-loaders``,
whose glTF loader reads ``KHR_gaussian_splatting``), driven by playwright.

:func:`open_in_babylon` serves the GLB and the two scripts from a temporary folder on 127.0.0.1, loads the GLB with
``BABYLON.SceneLoader.ImportMeshAsync``, frames it with the default camera and reports what the loader built (class
names, ``getTotalVertices()`` of the ``GaussianSplattingMesh``: its splat count) and a screenshot.

Run by hand for the screenshot in ``docs/`` (the README donut's last frame)::

    python tests/glb_browser.py out/donut_glb/donut_v3dg/frame_0036.glb docs/glb_babylon_donut.png
"""
from __future__ import annotations

import functools
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-quic",
        "--no-first-run", "--disable-component-update", "--disable-sync", "--use-gl=swiftshader",
        "--enable-unsafe-swiftshader"]
SCRIPTS = {"babylon.js": "babylonjs/babylon.js", "babylonjs.loaders.min.js": "babylonjs-loaders/babylonjs.loaders.min.js"}
INSTALL = "npm install -g babylonjs babylonjs-loaders"

PAGE = """<!doctype html><html><body style="margin:0;background:#000">
<canvas id="c" width="800" height="600" style="width:800px;height:600px"></canvas>
<script src="babylon.js"></script><script src="babylonjs.loaders.min.js"></script>
<script>
window.result = null;
(async () => {
  try {
    const engine = new BABYLON.Engine(document.getElementById("c"), true, {preserveDrawingBuffer: true});
    const scene = new BABYLON.Scene(engine);
    scene.clearColor = new BABYLON.Color4(0, 0, 0, 1);
    const r = await BABYLON.SceneLoader.ImportMeshAsync("", "./", "frame.glb", scene);
    const splats = r.meshes.filter(m => m.getClassName() === "GaussianSplattingMesh");
    scene.createDefaultCamera(true, true, true);
    scene.activeCamera.alpha = -Math.PI / 2; scene.activeCamera.beta = 1.1;
    engine.runRenderLoop(() => scene.render());
    const groups = r.animationGroups || [];
    groups.forEach(g => g.pause());
    window.seek = (fraction) => {            // an animation group at a fraction of its length: visible splat meshes
      groups.forEach(g => g.goToFrame(g.from + fraction * (g.to - g.from)));
      scene.render();
      return splats.filter(m => m.isVisible && m.isEnabled()).map(m => m.name);
    };
    window.result = {classes: r.meshes.map(m => m.getClassName()), names: splats.map(m => m.name),
                     splats: splats.map(m => m.getTotalVertices()), animation_groups: groups.length,
                     version: BABYLON.Engine.Version};
  } catch (e) { window.result = {error: String(e)}; }
})();
</script></body></html>"""


def chromium() -> str | None:
    """Debian's Chromium or its headless build, or None."""
    return shutil.which("chromium") or shutil.which("chromium-headless-shell")


def babylon_dir() -> Path | None:
    """The ``node_modules`` folder holding both Babylon.js packages: ``$GASP_NODE_MODULES``, else ``npm root -g``."""
    roots = [os.environ.get("GASP_NODE_MODULES")]
    if shutil.which("npm"):
        try:
            roots.append(subprocess.run(["npm", "root", "-g"], capture_output=True, text=True, timeout=30).stdout.strip())
        except (OSError, subprocess.TimeoutExpired):
            pass
    for r in roots:
        if r and all((Path(r) / rel).is_file() for rel in SCRIPTS.values()):
            return Path(r)
    return None


def open_in_babylon(glb: Path, png: Path, modules: Path, wait_s: float = 8.0, seek: tuple[float, ...] = ()) -> dict:
    """Load ``glb`` in Babylon.js in headless Chromium, wait ``wait_s`` seconds of rendering, save ``png``.

    Returns the page's report: ``classes`` (the meshes built), ``names`` and ``splats`` (``getTotalVertices()``)
    of each ``GaussianSplattingMesh``, ``animation_groups``, ``version``; or ``error``. With ``seek``: ``visible``,
    per fraction of the animation, the names of the splat meshes visible there (``png`` is taken at the last).
    """
    from playwright.sync_api import sync_playwright
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for name, rel in SCRIPTS.items():
            shutil.copy(modules / rel, d / name)
        shutil.copy(glb, d / "frame.glb")
        (d / "index.html").write_text(PAGE)
        handler = functools.partial(type("Quiet", (SimpleHTTPRequestHandler,), {"log_message": lambda *a: None}),
                                    directory=str(d))
        server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=chromium(), args=ARGS)
                page = browser.new_page(viewport={"width": 800, "height": 600})
                page.goto(f"http://127.0.0.1:{server.server_address[1]}/index.html")
                t0, result = time.time(), None
                while result is None and time.time() - t0 < 120:
                    time.sleep(0.5)
                    result = page.evaluate("window.result")
                if seek and result and "error" not in result:
                    result["visible"] = [page.evaluate(f"window.seek({x})") for x in seek]
                time.sleep(wait_s)
                page.screenshot(path=str(png))
                browser.close()
        finally:
            server.shutdown()
            server.server_close()
    return result or {"error": "the page reported nothing in 120 s"}


if __name__ == "__main__":
    mods = babylon_dir()
    if mods is None or chromium() is None:
        sys.exit(f"needs Chromium and Babylon.js ({INSTALL}, or GASP_NODE_MODULES=<node_modules>)")
    print(json.dumps(open_in_babylon(Path(sys.argv[1]), Path(sys.argv[2]), mods)))
