#!/usr/bin/env bash
# Install everything quadpipe needs on a fresh Debian machine: system packages, then a Python
# virtual environment in .venv with quadpipe and its test tools. Safe to run again: it skips
# what is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

# open3d's headless renderer (software Vulkan via Mesa) and its runtime libraries.
DEBIAN_PACKAGES=(libusb-1.0-0 libvulkan1 mesa-vulkan-drivers libegl1 libgl1 libgomp1)

source scripts/debian.sh
install_debian_packages open3d "${DEBIAN_PACKAGES[@]}"

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "creating .venv"
  "$PYTHON" -m venv .venv
fi
stamp=.venv/.quadpipe-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "installing quadpipe and its Python dependencies into .venv"
  .venv/bin/python -m pip install --quiet --disable-pip-version-check -e ".[test]"
  touch "$stamp"
fi

# Node tools for the exporter tests: the Khronos glTF validator and three.js.
scripts/install_node_tools.sh

# Blender as a Python module (bpy), in its own environment .venv-blender, for tests/test_blender.py.
scripts/install_blender.sh
