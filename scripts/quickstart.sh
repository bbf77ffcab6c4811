#!/usr/bin/env bash
# Sets everything up (idempotently), builds vorl, and runs the main job on the bundled example:
# `vorl eval` on examples/plant (detections scored against its truth.json), with an overlay
# picture per frame written to out/overlays/, then `vorl detect` on one frame.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cargo build --release -p vorl-host-sim --bin vorl
VORL=target/release/vorl

echo
echo "==> vorl eval examples/plant --overlay out/overlays"
"$VORL" eval examples/plant --overlay out/overlays

echo
echo "==> vorl detect on one frame"
"$VORL" detect --background examples/plant/background.png --templates examples/plant/templates \
    examples/plant/frames/f000.png

echo
echo "Overlay pictures: out/overlays/*.png (green: known part, red: unknown, yellow: touching the edge)"
