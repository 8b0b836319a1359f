#!/usr/bin/env bash
# One-shot set-up of a fresh machine: Debian packages flexhrc uses at run time, then a virtual
# environment in .venv with flexhrc and every optional extra (editable install).
# Idempotent and quick when nothing changed: it re-installs only when pyproject.toml changes.
set -euo pipefail
cd "$(dirname "$0")/.."

PY=${PYTHON:-python3}
VENV=${VENV:-.venv}
# graphviz: `dot` renders AND/OR graphs and behaviour networks to SVG/PNG;
# chromium: the headless browser the operator panel's tests drive (through Playwright);
# gcc, python3-dev: the install compiles the ANDOR reader's common case (optional: without them
# the pure-Python reader does the reading)
DEBIAN_PACKAGES=(graphviz chromium gcc python3-dev)

missing=()
for pkg in "${DEBIAN_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else SUDO="none"; fi
    if [ "$SUDO" = "none" ]; then
        echo "setup: please install the Debian packages: ${missing[*]} (needs root); continuing without them" >&2
    else
        echo "setup: installing Debian packages: ${missing[*]}" >&2
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
    fi
fi

if [ ! -x "$VENV/bin/python" ]; then
    echo "setup: creating $VENV" >&2
    "$PY" -m venv "$VENV"
fi
stamp="$VENV/.flexhrc-setup"
# (setup.py and the C source too: the compiled ANDOR reader is built by the install)
want="$(cat pyproject.toml setup.py src/flexhrc/representation/formats/_andor_fast.c | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    echo "setup: installing flexhrc and its extras into $VENV (first time: a few minutes)" >&2
    "$VENV/bin/python" -m pip install -q --upgrade pip
    "$VENV/bin/python" -m pip install -q -e ".[all,dev]"
    echo "$want" > "$stamp"
fi
# the kinematic simulator's compiled controller loop (numba): compiled once into numba's on-disk
# cache here, so the demo and the tests load it (~0.4 s) instead of compiling it (~15 s)
"$VENV/bin/python" - <<'PY'
import sys
from flexhrc.action import kernel
if kernel.available():
    from pathlib import Path
    fresh = not any(Path(kernel.__file__).parent.joinpath("__pycache__").glob("kernel._integrate-*.nbi"))
    if fresh:
        print("setup: compiling the kinematic simulator's control loop (numba, once)", file=sys.stderr)
    kernel.warm_up()
PY
