#!/usr/bin/env bash
# Lint, format check and type check, as CI runs them (.ci/run, before the tests). Configuration
# in pyproject.toml ([tool.ruff], [tool.mypy]); the tools are pinned in the `test` extra.
# Run every check, report each, and exit 1 if any failed. Fix most findings with
#   .venv/bin/ruff check --fix . && .venv/bin/ruff format .
set -uo pipefail
cd "$(dirname "$0")/.."
BIN=.venv/bin

failed=()
check() {
  local name=$1; shift
  echo "== $name: $*"
  "$@" || failed+=("$name")
}
check "ruff check" "$BIN/ruff" check .
check "ruff format" "$BIN/ruff" format --check --output-format concise .
check "mypy" "$BIN/python" -m mypy

if [ ${#failed[@]} -gt 0 ]; then
  echo "lint failed: ${failed[*]}" >&2
  exit 1
fi
echo "lint: all clean"
