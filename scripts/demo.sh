#!/usr/bin/env bash
# Install everything, then run quadpipe end to end on the built-in dog: model, a walk (the
# `walk` gait) over a hill baked to glTF / USD / BVH / raw clip, a contact sheet and a short video.
# Outputs go to out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install.sh
OUT="${QUADPIPE_DEMO_OUT:-out/demo}"
mkdir -p "$OUT"
QP=.venv/bin/quadpipe
set -x
$QP animals
$QP convert dog -o "$OUT/dog.xml"
$QP validate configs/controllers
$QP bake --animal dog --controller walk --scene hill --seconds 12 \
  -o "$OUT/dog_hill.npz" -o "$OUT/dog_hill.glb" -o "$OUT/dog_hill.usdc" -o "$OUT/dog_hill.bvh"
$QP render "$OUT/dog_hill.npz" -o "$OUT/dog_hill.png" -o "$OUT/dog_hill.mp4" --width 480 --height 360 --view side
{ set +x; } 2>/dev/null
cat <<MSG
demo outputs in $OUT/:
  dog.xml                 the dog's physical model (python -m mujoco.viewer --mjcf $OUT/dog.xml)
  dog_hill.glb / .usdc    the walk over the hill, for Blender, Maya, usdview, three.js
  dog_hill.bvh / .npz     the same for retargeting tools / quadpipe itself
  dog_hill.metrics.json   distance, speed, pelvis heights, falls
  dog_hill.png / .mp4     a contact sheet and a video
MSG
