#!/usr/bin/env bash
# Headless tests of the Blender add-on: a Python 3.11 virtual environment with bpy 5.0 (PyPI),
# the squish wheel and pytest; the extension zip built from that wheel and installed by
# Blender's own extension installer in the tests.
#
#   blender/test.sh                 # builds the wheel (dev profile), the zip, runs the tests
#   SQUISH_WHEEL=path.whl blender/test.sh   # reuses a wheel built before
#   BPY_VERSION="4.2.*" blender/test.sh      # another bpy (4.2, the manifest's minimum, passes too)
#
# bpy 4.2–5.0 support CPython 3.11 only: PYTHON (default python3.11) must be one.
set -euo pipefail
cd "$(dirname "$0")/.."
python="${PYTHON:-python3.11}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$python" -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet --upgrade pip
"$work/venv/bin/pip" install --quiet "bpy==${BPY_VERSION:-5.0.*}" "pytest>=7"
wheel="${SQUISH_WHEEL:-}"
if [ -z "$wheel" ]; then
    MATURIN_PEP517_ARGS="--profile dev" "$work/venv/bin/pip" wheel --quiet --no-deps -w "$work/wheels" ./crates/squish-py
    wheel="$(ls "$work"/wheels/squish-*.whl)"
fi
# The tests import squish themselves (to count intersections, read the schema); the add-on
# gets its own copy from the zip, as in Blender.
"$work/venv/bin/pip" install --quiet "$wheel"
zip="$("$work/venv/bin/python" blender/build.py --wheel "$wheel" --out "$work/dist" | tail -n 1)"
# Blender writes the installed extension under the user's config folder: a scratch one.
HOME="$work/home" SQUISH_BLENDER_ZIP="$zip" "$work/venv/bin/python" -m pytest -q -p no:cacheprovider blender/tests "$@"
