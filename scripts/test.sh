#!/usr/bin/env bash
# Runs every check of the project, as CI does: set-up (idempotent), formatting, lints, the API
# docs, the microcontroller build of the core, the panic-never link, the whole test suite (unit,
# doc, integration, property and the firmware-in-QEMU test), a build of the benchmarks, and a
# short run of every fuzz target (VORL_SKIP_FUZZ=1 leaves it out), and the Python package:
# its lints, a release build into .venv and pytest against the `vorl` program
# (VORL_SKIP_PYTHON=1 leaves it out).
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "set-up"
bash scripts/setup.sh

step "formatting (cargo fmt --check)"
cargo fmt --all -- --check

step "lints (cargo clippy -D warnings)"
cargo clippy --workspace --all-targets -- -D warnings

step "API docs (cargo doc, warnings are errors: broken or private links)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet

step "vorl serve's camera source (cargo clippy --features camera: V4L2 through the v4l crate)"
cargo clippy -p vorl-host-sim --features camera -- -D warnings

step "vorl-core for the MCU (thumbv7em-none-eabihf, no std, no alloc)"
cargo build -p vorl-core --target thumbv7em-none-eabihf --release

step "panic-never: vorl-core links with no panic path left (thumbv7em-none-eabihf, fat LTO)"
(cd panic-never && cargo build --release) || {
    echo "a panic path of vorl-core survives optimisation: bash scripts/panic-sites.sh lists where" >&2
    exit 1
}

step "tests (cargo test --workspace)"
timeout 1800 cargo test --workspace

if [ "${VORL_SKIP_PYTHON:-0}" = "1" ]; then
    step "Python package: skipped (VORL_SKIP_PYTHON=1)"
else
    step "Python package (python/: fmt, clippy -D warnings, maturin build into .venv, pytest)"
    # Its own cargo workspace (an extension module links against the interpreter that loads
    # it), built in the repository's target folder: one folder to cache, and the crates it
    # shares with the workspace at the same features (build scripts, proc macros) built once.
    (
        export CARGO_TARGET_DIR="$PWD/target"
        cargo fmt --manifest-path python/Cargo.toml -- --check
        cargo clippy --manifest-path python/Cargo.toml -- -D warnings
        VIRTUAL_ENV="$PWD/.venv" PATH="$PWD/.venv/bin:$PATH" \
            maturin develop --release --quiet --manifest-path python/Cargo.toml
    )
    # Against the program as `cargo test` just built it.
    VORL_BIN="$PWD/target/debug/vorl" .venv/bin/python -m pytest -q python/tests
fi

step "benchmarks build (cargo bench --no-run)"
cargo bench --workspace --no-run

if [ "${VORL_SKIP_FUZZ:-0}" = "1" ]; then
    step "fuzz targets: skipped (VORL_SKIP_FUZZ=1)"
else
    step "fuzz targets, ${VORL_CI_FUZZ_SECONDS:-30} s each in two lanes (scripts/fuzz.sh; any crash fails)"
    # Built once, then two lanes of four targets side by side (one per core).
    export VORL_FUZZ_SECONDS="${VORL_CI_FUZZ_SECONDS:-30}"
    VORL_FUZZ_BUILD_ONLY=1 bash scripts/fuzz.sh
    bash scripts/fuzz.sh recognizer borders library matching >target/fuzz-lane-1.log 2>&1 &
    lane=$!
    lane2=0
    bash scripts/fuzz.sh partial_volume geometry stereo calibration || lane2=$?
    lane1=0
    wait "$lane" || lane1=$?
    cat target/fuzz-lane-1.log
    if [ "$lane1" -ne 0 ] || [ "$lane2" -ne 0 ]; then
        echo "a fuzz target crashed (see above)" >&2
        exit 1
    fi
fi

printf '\nall checks passed\n'
