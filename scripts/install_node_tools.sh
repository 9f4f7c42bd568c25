#!/usr/bin/env bash
# Install the Node tools the exporter tests call (the Khronos glTF validator and three.js, pinned
# in tests/js/package-lock.json) into tests/js/node_modules. Safe to run again: it skips the
# install when node_modules is already there and up to date. Without node/npm it only warns
# (the Node tests are then skipped).
set -euo pipefail
cd "$(dirname "$0")/../tests/js"

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "warning: node/npm not found; the glTF validator and three.js tests will be skipped" >&2
  exit 0
fi
if [ -d node_modules ] && [ node_modules/.package-lock.json -nt package-lock.json ]; then
  exit 0
fi
echo "installing Node test tools (gltf-validator, three) into tests/js/node_modules"
npm ci --no-audit --no-fund --loglevel=error
