#!/usr/bin/env bash
# Installs everything vorl's build and tests need, idempotently:
#   - the Cortex-M4F target (thumbv7em-none-eabihf) and the llvm-tools, clippy and rustfmt
#     components, via rustup;
#   - qemu-system-arm (to run the firmware example), via apt-get, when it is missing;
#   - chromium and chromium-driver (the browser test of `vorl serve`), via apt-get, when missing;
#   - libclang (the camera feature's V4L2 bindings are generated at build), via apt-get, when missing;
#   - netcat-openbsd (`nc`, the README's robot-port example), via apt-get, when missing and this
#     user can install it;
#   - the nightly toolchain (minimal profile) and cargo-fuzz, for the fuzz targets
#     (scripts/fuzz.sh), unless VORL_SKIP_FUZZ=1;
#   - for the Python package (python/): a virtual environment of the project's own, .venv/, with
#     maturin, numpy and pytest from PyPI (python3 and its venv module via apt-get when missing),
#     unless VORL_SKIP_PYTHON=1.
# Safe to run again: each step checks first. Needs the Rust toolchain (rustup) already.
set -euo pipefail

say() { printf '[setup] %s\n' "$*"; }

# Whether this user can apt-get install: root, or sudo at hand.
can_apt() { [ "$(id -u)" = "0" ] || command -v sudo >/dev/null 2>&1; }

# apt_install WHAT HINT PACKAGE...: installs Debian packages (through sudo unless root). A user
# who cannot is told that WHAT is missing, then HINT (how to go on without it), and set-up stops.
apt_install() {
    local what=$1 hint=$2
    shift 2
    if ! can_apt; then
        echo "[setup] error: ${what} missing and this user cannot apt-get install it (no root, no sudo)${hint:+; ${hint}}" >&2
        exit 1
    fi
    local sudo=""
    [ "$(id -u)" = "0" ] || sudo="sudo"
    say "installing $* (apt-get)"
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

if ! command -v rustup >/dev/null 2>&1; then
    echo "[setup] error: rustup not found; install the Rust toolchain first (https://rustup.rs)" >&2
    exit 1
fi

if rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
    say "target thumbv7em-none-eabihf: present"
else
    say "adding target thumbv7em-none-eabihf"
    rustup target add thumbv7em-none-eabihf
fi

for comp in llvm-tools clippy rustfmt; do
    if rustup component list --installed | grep -q "^${comp}"; then
        say "component ${comp}: present"
    else
        say "adding component ${comp}"
        rustup component add "${comp}"
    fi
done

if command -v qemu-system-arm >/dev/null 2>&1; then
    say "qemu-system-arm: present"
elif [ "${VORL_SKIP_QEMU:-0}" = "1" ]; then
    say "qemu-system-arm: missing, skipped (VORL_SKIP_QEMU=1); the firmware run test will be skipped"
else
    apt_install "qemu-system-arm is" "set VORL_SKIP_QEMU=1 to go on without the firmware run" qemu-system-arm
    say "qemu-system-arm: $(qemu-system-arm --version | head -n 1)"
fi
if [ "${VORL_SKIP_FUZZ:-0}" = "1" ]; then
    say "nightly and cargo-fuzz: skipped (VORL_SKIP_FUZZ=1); scripts/test.sh skips the fuzz run"
else
    if rustup toolchain list | grep -q '^nightly'; then
        say "toolchain nightly: present"
    else
        say "installing the nightly toolchain (for cargo fuzz)"
        rustup toolchain install nightly --profile minimal
    fi
    if cargo fuzz --version >/dev/null 2>&1; then
        say "cargo-fuzz: $(cargo fuzz --version)"
    else
        say "installing cargo-fuzz (cargo install, a few minutes)"
        cargo install cargo-fuzz --locked
    fi
fi
# Chromium and chromedriver: the browser test of `vorl serve`'s page (host-sim/tests/serve.rs)
# drives headless Chromium through chromedriver. Outside CI the test skips, saying so, when
# they are missing and this user cannot install them (VORL_SKIP_BROWSER=1 skips the install).
if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then
    say "chromium and chromedriver: present"
elif [ "${VORL_SKIP_BROWSER:-0}" = "1" ]; then
    say "chromium, chromedriver: missing, skipped (VORL_SKIP_BROWSER=1); the browser test skips outside CI"
else
    apt_install "chromium and chromedriver are" "set VORL_SKIP_BROWSER=1 to go on without the browser test" \
        chromium chromium-driver
    say "chromium: $(chromium --version 2>/dev/null | head -n 1)"
fi
# netcat: the README talks to `vorl serve`'s robot port with `nc` (no test needs it, so a
# user who cannot install it is told and set-up goes on).
if command -v nc >/dev/null 2>&1; then
    say "nc: present"
elif can_apt; then
    apt_install "nc is" "" netcat-openbsd
else
    say "nc: missing and this user cannot install it; the robot port answers any TCP client"
fi
# libclang: the V4L2 bindings of `vorl serve`'s camera feature (the v4l crate) are generated
# when it is built (bindgen); scripts/test.sh lints that feature.
have_libclang() {
    local f
    for f in /usr/lib/llvm-*/lib/libclang.so* /usr/lib/*/libclang.so* /usr/lib/*/libclang-[0-9]*.so*; do
        [ -e "$f" ] && return 0
    done
    return 1
}
if have_libclang; then
    say "libclang: present"
else
    apt_install "libclang is" "" libclang-dev
fi
if [ "${VORL_SKIP_PYTHON:-0}" = "1" ]; then
    say "python: skipped (VORL_SKIP_PYTHON=1); scripts/test.sh skips the Python package"
else
    root="$(cd "$(dirname "$0")/.." && pwd)"
    venv="${root}/.venv"
    apt_python() {
        apt_install "$*" "set VORL_SKIP_PYTHON=1 to go on without the Python package" "$@"
    }
    command -v python3 >/dev/null 2>&1 || apt_python python3 python3-venv
    if [ ! -x "${venv}/bin/python" ]; then
        say "creating the virtual environment ${venv}"
        if ! python3 -m venv "${venv}" >/dev/null 2>&1; then
            # Debian keeps venv (ensurepip) in a package of its own.
            rm -rf "${venv}"
            apt_python python3-venv
            python3 -m venv "${venv}"
        fi
    fi
    if "${venv}/bin/python" -c "import numpy, pytest" >/dev/null 2>&1 && "${venv}/bin/maturin" --version >/dev/null 2>&1; then
        say "python: $("${venv}/bin/python" --version), $("${venv}/bin/maturin" --version), numpy and pytest present in .venv"
    else
        say "installing maturin, numpy and pytest into .venv (pip)"
        "${venv}/bin/python" -m pip install --quiet --disable-pip-version-check maturin numpy pytest
    fi
fi
say "done"
