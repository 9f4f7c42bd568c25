#!/usr/bin/env bash
# Install everything, then run quadpipe end to end on the built-in dog. Outputs go to out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh
OUT=out/demo
mkdir -p "$OUT"
QP=.venv/bin/quadpipe
set -x
$QP animals
$QP inspect dog --format json > "$OUT/dog.json"
$QP convert dog -o "$OUT/dog.xml"
{ set +x; } 2>/dev/null
echo "demo outputs in $OUT/: dog.xml (MJCF: python -m mujoco.viewer $OUT/dog.xml), dog.json"
