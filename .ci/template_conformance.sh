#!/usr/bin/env bash
# An engine developed outside this repository, as its author would test it: a fresh venv with only the
# core and the template engine (non-editable), then `gasp engines` must list it and `gasp conform` must
# pass, through the installed kit (gasp_core.testing), not through conformance_tests/.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
venv="$(mktemp -d)/venv"
trap 'rm -rf "$(dirname "$venv")"' EXIT
python -m venv "$venv"
"$venv/bin/python" -m pip install -q -e .
"$venv/bin/python" -m pip install -q examples/engine_template
cd "$(dirname "$venv")"  # away from the checkout: nothing imported from the working tree but the core
"$venv/bin/gasp" engines | tee engines.txt
grep -q "^example_springs " engines.txt
"$venv/bin/gasp" conform example_springs
echo "== template conformance: $((SECONDS - start)) s =="
