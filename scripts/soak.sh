#!/usr/bin/env bash
# The soak runs of docs/reliability.md ("Soak run"):
#
#   bash scripts/soak.sh                   # both long runs: host 100 000 frames, firmware 10 000
#   bash scripts/soak.sh --host 100000     # host only: `vorl soak --frames N` (release build)
#   bash scripts/soak.sh --firmware 10000  # firmware only: N frames through the firmware's
#                                          # recognizer under QEMU (-append "soak N")
#
# The short versions are in the default suite: `cargo test -p vorl-tests --test soak` (host,
# 280 frames) and `cargo test -p vorl-tests --test firmware firmware_soak_short` (20 frames).
# Outputs go to target/soak-host.txt and target/soak-firmware.txt; the exit status is non-zero
# when a frame failed or differed from a fresh recognizer (host) or from its variant's first
# frame (firmware).
set -euo pipefail
cd "$(dirname "$0")/.."

host=100000
firmware=10000
if [ $# -gt 0 ]; then
    host=0
    firmware=0
    while [ $# -gt 0 ]; do
        case "$1" in
            --host) host="$2"; shift 2 ;;
            --firmware) firmware="$2"; shift 2 ;;
            *) echo "usage: $0 [--host N] [--firmware N]" >&2; exit 2 ;;
        esac
    done
fi

mkdir -p target
if [ "$host" -gt 0 ]; then
    cargo build --release -p vorl-host-sim --bin vorl
    echo "==> host: vorl soak --frames $host"
    start=$(date +%s)
    ./target/release/vorl soak --frames "$host" | tee target/soak-host.txt
    echo "host soak: $(( $(date +%s) - start )) s"
fi
if [ "$firmware" -gt 0 ]; then
    (cd firmware-example && cargo build --release)
    elf=firmware-example/target/thumbv7em-none-eabihf/release/vorl-firmware-example
    echo "==> firmware: $firmware frames under QEMU"
    start=$(date +%s)
    qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -kernel "$elf" -append "soak $firmware" > target/soak-firmware.txt
    grep -E '^soak_(progress|summary|mismatch|error)' target/soak-firmware.txt
    echo "firmware soak: $(( $(date +%s) - start )) s"
fi
