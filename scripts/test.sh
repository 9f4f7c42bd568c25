#!/usr/bin/env bash
# Install what is missing, then run the whole test suite (slow simulations included) on all cores.
# --dist loadscope keeps each test module on one worker, so a module's cached simulations run once.
# Extra arguments go to pytest, e.g. scripts/test.sh -m "not slow" -k dog
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh
exec .venv/bin/python -m pytest -n auto --dist loadscope "$@"
