#!/usr/bin/env bash
# Sets up the OpenCV peer's Python environment, idempotently: a venv in bench/.venv with the
# pinned packages of bench/requirements.txt (opencv-python-headless, numpy) from PyPI. Nothing is
# installed system-wide by pip. Safe to run again: when the venv already holds the pinned
# versions it does nothing.
#
# Needs python3 (3.9 or newer) with its venv module. When that is missing (Debian ships it in
# the python3-venv package) it is installed with apt-get, as root or through sudo, like
# scripts/setup.sh does for qemu.
set -euo pipefail

say() { printf '[setup_peer] %s\n' "$*"; }

HERE="$(cd "$(dirname "$0")" && pwd)"
VENV="$HERE/.venv"
REQ="$HERE/requirements.txt"
PY="${PYTHON:-python3}"

apt_install() {
    local SUDO=""
    if [ "$(id -u)" != "0" ]; then
        if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
            echo "[setup_peer] error: $* missing and this user cannot apt-get install it (no root, no sudo)" >&2
            exit 1
        fi
    fi
    if ! command -v apt-get >/dev/null 2>&1; then
        echo "[setup_peer] error: $* missing and there is no apt-get; install Python 3 with its venv module" >&2
        exit 1
    fi
    say "installing $* (apt-get)"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

if ! command -v "$PY" >/dev/null 2>&1; then
    apt_install python3 python3-venv
fi
if ! "$PY" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 9) else 1)'; then
    echo "[setup_peer] error: $("$PY" --version 2>&1) is too old; the peer needs Python 3.9 or newer" >&2
    exit 1
fi

# The pinned versions, as "name==version" lines.
pins=$(grep -E '^[A-Za-z0-9_.-]+==' "$REQ")
check_pins() {
    "$VENV/bin/python" - "$pins" <<'PYEOF'
import sys
from importlib.metadata import version, PackageNotFoundError
ok = True
for line in sys.argv[1].split():
    name, want = line.split("==")
    try:
        have = version(name)
    except PackageNotFoundError:
        have = None
    if have != want:
        ok = False
import cv2, numpy  # noqa: F401  (the packages must also import)
sys.exit(0 if ok else 1)
PYEOF
}

if [ -x "$VENV/bin/python" ] && check_pins >/dev/null 2>&1; then
    say "venv $VENV: present with $(echo $pins)"
    say "done"
    exit 0
fi

if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c 'import sys' >/dev/null 2>&1; then
    rm -rf "$VENV"
    if ! "$PY" -m venv "$VENV" >/dev/null 2>&1; then
        rm -rf "$VENV"
        apt_install python3-venv
        "$PY" -m venv "$VENV"
    fi
    say "created venv $VENV ($("$VENV/bin/python" --version 2>&1))"
fi

say "installing $(echo $pins) (pip, into the venv)"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$REQ"
check_pins || { echo "[setup_peer] error: the venv does not hold the pinned versions after pip install" >&2; exit 1; }
say "installed: $("$VENV/bin/python" -c 'import cv2, numpy; print("opencv", cv2.__version__, "numpy", numpy.__version__)')"
say "done"
