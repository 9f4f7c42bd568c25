#!/usr/bin/env bash
# Install Blender as a Python module (bpy from PyPI) into its own virtual environment,
# .venv-blender, for tests/test_blender.py (it imports clips with the script that
# `quadpipe blender-script` writes). bpy wheels exist for one Python version only (3.11 for
# Blender 5.0), so this environment is kept apart from .venv. Safe to run again: it skips what is
# already there (a stamp file records the installed version).
set -euo pipefail
cd "$(dirname "$0")/.."

BPY_VERSION="5.0.1"
# Shared libraries bpy's wheel links against on a bare Debian machine (X11 client libraries and
# the software OpenGL/EGL stack; no display is opened in background mode).
DEBIAN_PACKAGES=(libxi6 libxxf86vm1 libxfixes3 libxrender1 libxkbcommon0 libsm6 libgl1 libegl1)

source scripts/debian.sh
install_debian_packages bpy "${DEBIAN_PACKAGES[@]}"

PYTHON="${BLENDER_PYTHON:-python3.11}"
if ! command -v "$PYTHON" >/dev/null; then
  echo "error: $PYTHON not found; bpy $BPY_VERSION needs Python 3.11 (set BLENDER_PYTHON)" >&2
  exit 1
fi
if [ ! -x .venv-blender/bin/python ]; then
  echo "creating .venv-blender ($("$PYTHON" --version))"
  "$PYTHON" -m venv .venv-blender
fi
stamp=.venv-blender/.quadpipe-bpy-$BPY_VERSION
if [ ! -f "$stamp" ]; then
  echo "installing bpy $BPY_VERSION into .venv-blender (about 1 GB)"
  .venv-blender/bin/python -m pip install --quiet --disable-pip-version-check "bpy==$BPY_VERSION"
  .venv-blender/bin/python -c "import bpy; print('bpy', bpy.app.version_string)"
  touch "$stamp"
fi
