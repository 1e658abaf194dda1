#!/usr/bin/env bash
# Optional CI tier: install Genesis (torch 2.13 CPU + genesis-world, ~4 GB) and the gasp-genesis
# plugin, then run the plugin's tests. .ci/run calls it only when time allows.
#
# Measured on the 2-core dev machine (genesis-world 1.4.5, torch 2.13.0+cpu, wheels cached locally):
#   install: torch 19 s, genesis-world 56 s when not yet installed (38 s when both already are);
#   tests (default, not slow): ~3.5 min with a cold kernel cache (~/.cache/quadrants), ~1.2 min
#   warm, of which 35-55 s is 'import genesis' alone.
# Arguments go to pytest instead of the default `-m "not slow"`, e.g. `-m "slow or not slow"`.
set -euo pipefail
cd "$(dirname "$0")/.."
export PIP_DISABLE_PIP_VERSION_CHECK=1 PYTHONUNBUFFERED=1
t0=$SECONDS
echo "== genesis tier: install =="
python -m pip install -q "torch==2.13.0"
python -m pip install -q genesis-world
python -m pip install -q -e . -e "plugins/genesis[engine,test]"
python - <<'PY'
import importlib.metadata as md
from gasp_core.seam.plugins import get_engine
print("genesis-world", md.version("genesis-world"), "| torch", md.version("torch"),
      "| gasp-genesis", md.version("gasp-genesis"))
get_engine("genesis")  # raises EngineError if the plugin cannot run here
PY
t1=$SECONDS
echo "== genesis tier: tests =="
if [ $# -eq 0 ]; then set -- -m "not slow"; fi
python -m pytest plugins/genesis/tests -p no:cacheprovider --durations=5 "$@"
t2=$SECONDS
echo "== genesis tier: install $((t1 - t0)) s, tests $((t2 - t1)) s =="
