#!/usr/bin/env bash
# Check that a change moves no animal differently and changes no baked byte: bake the same
# matrix with the working tree's code and with a git revision's code, and compare every file.
#
#   tools/same_outputs.sh [REV]      REV defaults to HEAD (i.e. check uncommitted changes)
#
# The matrix: every animal x every shipped controller for 3 s on the flat scene (.npz .glb
# .usdc .usda .bvh and metrics, via `quadpipe batch`), the dog's walk on every other shipped
# scene, and auto_gait on the dog, the rat and the horse recorded at 120 fps (every physics step
# for the dog and horse). About 1-2 minutes per tree on 2 cores. Exit 0 when every file is
# byte-identical, 1 otherwise (the differing files are listed).
set -euo pipefail
cd "$(dirname "$0")/.."
REV=${1:-HEAD}
PY=$PWD/.venv/bin/python
WORK=$(mktemp -d)
trap 'git worktree remove --force "$WORK/base" >/dev/null 2>&1 || true; rm -rf "$WORK"' EXIT INT TERM
git worktree add -q --detach "$WORK/base" "$REV"

bake_matrix() {  # bake_matrix TREE OUT
  local tree=$1 out=$2 scene
  mkdir -p "$out"
  (cd "$tree" && export PYTHONPATH="$tree" && {
    "$PY" -m quadpipe batch -a all -c all -s 3 -f npz -f glb -f usdc -f usda -f bvh -o "$out/matrix" -j 2 -q >/dev/null
    for scene in $(ls configs/scenes | sed 's/\.yaml$//'); do
      [ "$scene" = flat ] && continue
      "$PY" -m quadpipe bake -a dog -c walk --scene "$scene" -s 3 \
        -o "$out/scene_$scene.npz" -o "$out/scene_$scene.glb" -o "$out/scene_$scene.usdc" >/dev/null
    done
    for animal in dog rat horse; do
      "$PY" -m quadpipe bake -a "$animal" -c auto_gait -s 3 --fps 120 -o "$out/fps120_$animal.npz" >/dev/null
    done
  })
}

echo "baking with $REV ($(git rev-parse --short "$REV"))..."
bake_matrix "$WORK/base" "$WORK/before"
echo "baking with the working tree..."
bake_matrix "$PWD" "$WORK/after"
if diff -rq "$WORK/before" "$WORK/after"; then
  echo "same outputs: $(find "$WORK/after" -type f | wc -l) files byte-identical"
else
  echo "outputs differ (files above)" >&2
  exit 1
fi
