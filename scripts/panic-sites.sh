#!/usr/bin/env bash
# Where vorl-core still reaches a panic: builds panic-never/ with `--features diagnose` (a panic
# handler that exists, so the program links) and lists every branch to a panic function of
# `core` (core::panicking::*, slice index and copy_from_slice length failures, unwrap, the
# sort's ord-violation check) in its disassembly, with the chain of inlined source lines
# (addr2line -i) that leads there. Nothing listed: the panic-never link passes.
#
#   bash scripts/panic-sites.sh                      # the default proof
#   bash scripts/panic-sites.sh calibration-fits     # with the calibration fits (nalgebra)
#   VORL_PANIC_DEPTH=12 bash scripts/panic-sites.sh  # longer inline chains
#
# Needs the llvm-tools component (llvm-objdump; scripts/setup.sh adds it) and binutils'
# addr2line for the source lines (without it, only the functions are listed).
set -euo pipefail
cd "$(dirname "$0")/.."

features="diagnose"
for f in "$@"; do features="$features,$f"; done
target_dir="${CARGO_TARGET_DIR:-$PWD/panic-never/target}"
(cd panic-never && cargo build --release --features "$features" --target-dir "$target_dir" >&2)
elf="$target_dir/thumbv7em-none-eabihf/release/vorl-panic-never"

sysroot="$(rustc --print sysroot)"
objdump="$(find "$sysroot" -name llvm-objdump -type f | head -n 1)"
if [ -z "$objdump" ]; then
    echo "llvm-objdump not found: rustup component add llvm-tools (scripts/setup.sh)" >&2
    exit 1
fi
dis="$(mktemp)"
trap 'rm -f "$dis"' EXIT
"$objdump" -d --no-show-raw-insn -C "$elf" >"$dis"

sites="$(awk '
/^[0-9a-f]+ <.*>:$/ { fn = $0; sub(/^[0-9a-f]+ </, "", fn); sub(/>:$/, "", fn); next }
/\t(b|bl|blx|b\.w|cb|cbz|cbnz|b[a-z][a-z]|b[a-z][a-z]\.w)\t/ && /panicking|slice_index_fail|len_mismatch_fail|panic_on_ord|panic_already|unwrap_failed|expect_failed/ {
    if (fn ~ /^core::/) next;
    addr = $1; sub(/:$/, "", addr); target = $0; sub(/.*</, "", target); sub(/>.*/, "", target);
    print addr "\t" fn "\t" target
}' "$dis")"

if [ -z "$sites" ]; then
    echo "no panic site: the panic-never link passes"
    exit 0
fi
depth="${VORL_PANIC_DEPTH:-8}"
count=0
while IFS=$'\t' read -r addr fn target; do
    count=$((count + 1))
    printf '== %s -> %s @ 0x%s\n' "${fn%%::h*}" "${target##*::}" "$addr"
    if command -v addr2line >/dev/null 2>&1; then
        addr2line -e "$elf" -i -f -C "0x$addr" | paste - - | sed "s|$PWD/||; s|/rustc/[^ ]*/library/||; s|$HOME/.cargo/registry/src/[^/]*/||" | head -n "$depth"
    fi
done <<<"$sites"
echo "$count panic site(s)"
exit 1
