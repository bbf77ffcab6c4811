#!/usr/bin/env bash
# Runs vorl's fuzz targets (fuzz/, cargo fuzz + libFuzzer on the nightly toolchain), each for a
# bounded time or number of executions, and fails on any crash, panic, failed check, leak-free
# out-of-memory or time-out. See docs/reliability.md.
#
#   bash scripts/fuzz.sh                       # every target, 30 s each
#   bash scripts/fuzz.sh matching library      # only these
#   VORL_FUZZ_SECONDS=300 bash scripts/fuzz.sh # longer
#   VORL_FUZZ_RUNS=1000000 bash scripts/fuzz.sh  # the long run: 10^6 executions per target
#   VORL_FUZZ_BUILD_ONLY=1 bash scripts/fuzz.sh  # build the targets, run none
#
# Inputs: fuzz/seeds/<target>/ (committed, read only) and fuzz/corpus/<target>/ (what the runs
# found, kept between runs, not committed). A crash leaves its input in fuzz/artifacts/<target>/
# and the run's log in <target dir>/fuzz/logs/<target>.log; reproduce it with
#   cd fuzz && cargo +nightly fuzz run -s none <target> artifacts/<target>/<file>
# The build has debug assertions and overflow checks on (cargo fuzz's default) and no sanitizer
# (`-s none`: vorl-core is `forbid(unsafe_code)`, so AddressSanitizer would only slow it).
# Needs the nightly toolchain and cargo-fuzz: scripts/setup.sh installs both.
set -euo pipefail
cd "$(dirname "$0")/.."

ALL=(recognizer borders library matching partial_volume geometry stereo calibration)
TARGETS=("$@")
if [ ${#TARGETS[@]} -eq 0 ]; then TARGETS=("${ALL[@]}"); fi
SECONDS_EACH="${VORL_FUZZ_SECONDS:-30}"
RUNS="${VORL_FUZZ_RUNS:-}"
TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}/fuzz"
LOGS="$TARGET_DIR/logs"

say() { printf '[fuzz] %s\n' "$*"; }

if ! cargo +nightly --version >/dev/null 2>&1; then
    echo "[fuzz] error: the nightly toolchain is missing; run scripts/setup.sh" >&2
    exit 1
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    echo "[fuzz] error: cargo-fuzz is missing; run scripts/setup.sh" >&2
    exit 1
fi

# Longest input per target: a frame pair of 128×96 with its header, a 200×64 byte mask, ...
max_len() {
    case "$1" in
        recognizer) echo 40000 ;;
        partial_volume) echo 25000 ;;
        borders) echo 16000 ;;
        geometry) echo 8192 ;;
        library) echo 8192 ;;
        *) echo 4096 ;;
    esac
}

say "building the targets (nightly, no sanitizer, debug assertions)"
(cd fuzz && cargo +nightly fuzz build -s none --target-dir "$TARGET_DIR")
BIN="$TARGET_DIR/$(rustc -vV | sed -n 's/^host: //p')/release"
if [ "${VORL_FUZZ_BUILD_ONLY:-0}" = "1" ]; then
    say "built; not run (VORL_FUZZ_BUILD_ONLY=1)"
    exit 0
fi

mkdir -p "$LOGS"
failed=()
summary=()
for t in "${TARGETS[@]}"; do
    mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
    if [ -n "$RUNS" ]; then
        limit=(-runs="$RUNS")
        say "$t: $RUNS executions"
    else
        limit=(-max_total_time="$SECONDS_EACH")
        say "$t: ${SECONDS_EACH} s"
    fi
    log="$LOGS/$t.log"
    start=$(date +%s)
    set +e
    # The binary cargo fuzz built, run directly (as `cargo fuzz run` would, without a cargo
    # process per target).
    (cd fuzz && "$BIN/$t" "corpus/$t" "seeds/$t" \
        "${limit[@]}" -max_len="$(max_len "$t")" -timeout=20 -rss_limit_mb=2048 \
        -print_final_stats=1 -artifact_prefix="artifacts/$t/") >"$log" 2>&1
    status=$?
    set -e
    took=$(( $(date +%s) - start ))
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1 || true)
    speed=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1 || true)
    cov=$(grep -o 'cov: [0-9]* ft: [0-9]*' "$log" | tail -n 1 || true)
    corpus=$(find "fuzz/corpus/$t" -type f | wc -l)
    line="$t: status $status, ${execs:-?} executions in ${took} s (${speed:-?}/s), ${cov:-cov ?}, corpus $corpus"
    summary+=("$line")
    if [ "$status" -ne 0 ]; then
        failed+=("$t")
        say "FAILED $line"
        grep -E 'panicked|ERROR|SUMMARY|Test unit written|assert' "$log" | head -n 20 >&2 || true
        say "log: $log"
    else
        say "$line"
    fi
done

printf '\n'
for s in "${summary[@]}"; do say "$s"; done
if [ ${#failed[@]} -ne 0 ]; then
    say "crashes in: ${failed[*]} (inputs in fuzz/artifacts/<target>/)"
    exit 1
fi
say "no crashes"
