#!/usr/bin/env bash
# The core's API docs with its stage folders in data-flow order (pixels, borders, shape, pose,
# recognizer, location, then library, params, budget, error, math), as core/src/lib.rs declares
# them. A stable `cargo doc` lists modules alphabetically; nightly rustdoc's
# `--sort-modules-by-appearance` keeps the declaration order (docs.rs is set up the same way in
# core/Cargo.toml). Needs the nightly toolchain (scripts/setup.sh installs it).
#
#   bash scripts/doc.sh            # writes target/doc-nightly/doc/vorl_core/index.html
#   bash scripts/doc.sh --open     # and opens it
set -euo pipefail
cd "$(dirname "$0")/.."
if ! rustup toolchain list | grep -q '^nightly'; then
    echo "[doc] error: the nightly toolchain is missing; run: bash scripts/setup.sh" >&2
    exit 1
fi
RUSTDOCFLAGS="-Zunstable-options --sort-modules-by-appearance" \
    cargo +nightly doc -p vorl-core --no-deps --target-dir target/doc-nightly "$@"
echo "[doc] target/doc-nightly/doc/vorl_core/index.html"
