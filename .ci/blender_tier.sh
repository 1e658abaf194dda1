#!/usr/bin/env bash
# Optional CI tier: Blender as a Python module (bpy) and the gasp-blender plugin, in a venv of its own
# (.ci/.venv-blender): bpy 5.0.1 requires numpy<2 (it installed 1.26.4 over 2.4.6) and would
# downgrade the main environment's numpy.
# Runs the plugin's tests, the soup exchange tests (Blender-written OBJ/PLY frames) and the conformance
# scenes on the 'blender' engine.
#
# Measured on the 2-core dev machine (bpy 5.0.1, Python 3.11, not cached, machine shared with other jobs):
#   'pip install bpy': 2 min 04 s wall (374 MB wheel, 821 MB installed); tests below ~3 min.
# Arguments go to pytest instead of the default `-m "not slow"`.
set -euo pipefail
cd "$(dirname "$0")/.."
export PIP_DISABLE_PIP_VERSION_CHECK=1 PYTHONUNBUFFERED=1
t0=$SECONDS
echo "== blender tier: install =="
python -m venv .ci/.venv-blender
PY=.ci/.venv-blender/bin/python
$PY -m pip install -q -e ".[test]" -e "plugins/blender[engine,test]"
$PY - <<'PYEOF'
import importlib.metadata as md
from gasp_core.seam.plugins import get_engine
print("bpy", md.version("bpy"), "| gasp-blender", md.version("gasp-blender"))
get_engine("blender")  # raises EngineError if the plugin cannot run here
PYEOF
t1=$SECONDS
echo "== blender tier: tests =="
if [ $# -eq 0 ]; then set -- -m "not slow"; fi
GASP_LOAD_PLUGINS=blender $PY -m pytest plugins/blender/tests tests/test_soup.py -p no:cacheprovider --durations=5 "$@"
GASP_LOAD_PLUGINS=blender $PY -m pytest conformance_tests -k blender -p no:cacheprovider "$@"
t2=$SECONDS
echo "== blender tier: install $((t1 - t0)) s, tests $((t2 - t1)) s =="
