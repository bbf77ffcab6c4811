#!/usr/bin/env bash
# Soak of `vorl serve` (opt-in: not part of scripts/test.sh; a few minutes in a release build).
#
# Runs FRAMES frames (default 100 000) through `vorl serve SET --fps 0` (as fast as the frames
# are processed; replay of examples/plant by default, or --source gen) on loopback ports, with
#   - a robot client sending TRG in a loop (and LAST and PING between), every answer checked:
#     `RES <frame> <n>`, exactly n part lines of six fields, `END`; `PONG`;
#   - a page's traffic every 150 ms, as the page polls: GET /api/last, then for its version
#     /api/overlay.json (the overlay's shapes) and /api/frame.bmp (the frame, 8-bit gray);
# and samples the server's resident memory (VmRSS in /proc/PID/status) every 5 s.
#
# Fails (exit 1) when: an answer is ERR, malformed or missing, the robot connection drops, an
# HTTP request fails, the server ends before the last frame or stops badly, or its RSS at the
# end exceeds its RSS after the warm-up (WARMUP frames, default 5 000) by more than MARGIN_MB
# (default 8 MiB). Prints the figures (frames, seconds, frames/s, triggers answered, RSS at
# warm-up, at the end and its highest) at the end, and the RSS samples as it goes.
#
# Measured (docs/performance.md, section `vorl serve`): replay, 100 016 frames in 179 s (558
# frames/s), RSS 17 812 kB after the warm-up, 18 024 kB at the end. `--source gen` draws every
# scene (about 50 frames/s here: 100 000 frames take over half an hour).
#
# Usage: scripts/soak-serve.sh [--frames N] [--warmup N] [--margin-mb M] [--source replay|gen]
#                              [--set DIR] [--vorl PATH] [--no-page]
#   --vorl PATH  the program to soak (default: target/release/vorl, built first by
#                `cargo build --release -p vorl-host-sim` unless --vorl is given)
# Needs python3 (the client) and Linux's /proc.
set -euo pipefail
cd "$(dirname "$0")/.."

FRAMES=100000
WARMUP=5000
MARGIN_MB=8
SOURCE=replay
SET=examples/plant
VORL=
PAGE=1
while [ $# -gt 0 ]; do
    case "$1" in
        --frames) FRAMES=$2; shift 2 ;;
        --warmup) WARMUP=$2; shift 2 ;;
        --margin-mb) MARGIN_MB=$2; shift 2 ;;
        --source) SOURCE=$2; shift 2 ;;
        --set) SET=$2; shift 2 ;;
        --vorl) VORL=$2; shift 2 ;;
        --no-page) PAGE=0; shift ;;
        -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
        *) echo "soak-serve: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
if [ -z "$VORL" ]; then
    cargo build --release -p vorl-host-sim >&2
    VORL=target/release/vorl
fi
SCRATCH=$(mktemp -d "${TMPDIR:-/tmp}/vorl-soak-serve.XXXXXX")
SERVER=
cleanup() {
    if [ -n "$SERVER" ] && kill -0 "$SERVER" 2>/dev/null; then
        kill -TERM "$SERVER" 2>/dev/null || true
        sleep 2
        kill -KILL "$SERVER" 2>/dev/null || true
    fi
    rm -rf "$SCRATCH"
}
trap cleanup EXIT
if [ "$SOURCE" = gen ] && [ "$SET" = examples/plant ]; then
    SET=$SCRATCH/gen-set   # the generator's set is written there first
fi

"$VORL" serve "$SET" --source "$SOURCE" --fps 0 --http 127.0.0.1:0 --robot 127.0.0.1:0 \
    >"$SCRATCH/out" 2>"$SCRATCH/err" &
SERVER=$!

status=0
python3 - "$SERVER" "$SCRATCH/out" "$FRAMES" "$WARMUP" "$MARGIN_MB" "$PAGE" <<'EOF' || status=$?
import json, re, socket, sys, threading, time, urllib.request

pid, out, frames, warmup, margin_mb, page = sys.argv[1:]
pid, frames, warmup, margin_kb, page = int(pid), int(frames), int(warmup), float(margin_mb) * 1024, page == "1"
problems = []

def fail(msg):
    problems.append(msg)
    print("soak-serve: FAIL: " + msg, flush=True)

def rss_kb():
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")

def alive():
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] not in "ZX"
    except OSError:
        return False

# The addresses the server prints at start.
web = robot = None
deadline = time.time() + 120
while time.time() < deadline and not (web and robot):
    text = open(out).read()
    m = re.search(r"^page +http://([^/\s]+)/", text, re.M)
    web = m and m.group(1)
    m = re.search(r"^robot port (\S+)", text, re.M)
    robot = m and m.group(1)
    if not alive():
        break
    time.sleep(0.1)
if not (web and robot):
    print("soak-serve: the server printed no addresses", file=sys.stderr)
    sys.exit(1)

def get(path):
    with urllib.request.urlopen(f"http://{web}{path}", timeout=30) as r:
        return r.status, r.read()

def last_seq():
    status, body = get("/api/last")
    return json.loads(body)["seq"]

stop = threading.Event()
counts = {"trg": 0, "last": 0, "ping": 0, "pages": 0}
PART = re.compile(r"^\S+ -?\d+\.\d{3} -?\d+\.\d{3} -?\d+\.\d{3} [01] (-?\d+\.\d{3}|nan)$")

def robot_client():
    host, port = robot.rsplit(":", 1)
    try:
        s = socket.create_connection((host, int(port)), timeout=30)
        f = s.makefile("rb")
        def line():
            l = f.readline()
            if not l.endswith(b"\n"):
                raise RuntimeError("the connection dropped")
            return l[:-1].decode("ascii")
        def result(cmd):
            s.sendall(cmd + b"\n")
            head = line()
            m = re.fullmatch(r"RES (\S+) (\d+)", head)
            if not m:
                raise RuntimeError(f"{cmd.decode()}: {head!r}")
            for _ in range(int(m.group(2))):
                l = line()
                if not PART.match(l):
                    raise RuntimeError(f"{cmd.decode()}: part line {l!r}")
            end = line()
            if end != "END":
                raise RuntimeError(f"{cmd.decode()}: {end!r} where END was due")
        i = 0
        while not stop.is_set():
            result(b"TRG")
            counts["trg"] += 1
            i += 1
            if i % 10 == 0:
                result(b"LAST")
                counts["last"] += 1
                s.sendall(b"PING\n")
                if line() != "PONG":
                    raise RuntimeError("PING not answered PONG")
                counts["ping"] += 1
        s.close()
    except Exception as e:  # noqa: BLE001 - every failure is reported
        if not stop.is_set() or problems == []:
            fail(f"robot client: {e}")
        stop.set()

def page_client():
    try:
        while not stop.is_set():
            status, body = get("/api/last")
            last = json.loads(body) if status == 200 else {}
            if status != 200 or last.get("error"):
                raise RuntimeError(f"/api/last: {status} {body[:200]!r}")
            v = last["version"]
            status, body = get(f"/api/overlay.json?v={v}")
            shapes = json.loads(body) if status == 200 else {}
            if status != 200 or not isinstance(shapes.get("parts"), list):
                raise RuntimeError(f"/api/overlay.json: {status} {body[:200]!r}")
            status, bmp = get(f"/api/frame.bmp?v={shapes['version']}")
            if status != 200 or not bmp.startswith(b"BM"):
                raise RuntimeError(f"/api/frame.bmp: {status}")
            counts["pages"] += 1
            time.sleep(0.15)
    except Exception as e:  # noqa: BLE001
        if not stop.is_set():
            fail(f"page: {e}")
        stop.set()

# The first frame, then the clients.
while True:
    try:
        last_seq()
        break
    except Exception:
        if not alive():
            print("soak-serve: the server ended before its first frame", file=sys.stderr)
            sys.exit(1)
        time.sleep(0.1)
threads = [threading.Thread(target=robot_client)]
if page:
    threads.append(threading.Thread(target=page_client))
for t in threads:
    t.start()

t0 = time.time()
warm_rss = warm_t = None
peak = 0
samples = []
next_sample = 0.0
seq = 0
while not stop.is_set():
    if not alive():
        fail(f"the server ended at frame {seq}")
        break
    seq = last_seq()
    now = time.time() - t0
    if warm_rss is None and seq >= warmup:
        warm_rss, warm_t = rss_kb(), now
        print(f"warm-up: frame {seq}, {now:.0f} s, RSS {warm_rss} kB", flush=True)
    if now >= next_sample:
        r = rss_kb()
        peak = max(peak, r)
        samples.append((seq, round(now, 1), r))
        print(f"frame {seq:7d}  {now:7.1f} s  RSS {r} kB  TRG answered {counts['trg']}", flush=True)
        next_sample = now + 5.0
    if seq >= frames:
        break
    time.sleep(0.2)
end_rss = rss_kb()
peak = max(peak, end_rss)
elapsed = time.time() - t0
stop.set()
for t in threads:
    t.join(timeout=60)

print(f"frames {seq} in {elapsed:.1f} s ({seq / elapsed:.0f} frames/s); TRG answered {counts['trg']}, "
      f"LAST {counts['last']}, PING {counts['ping']}, page polls {counts['pages']}")
if warm_rss is None:
    fail(f"never reached the warm-up ({warmup} frames)")
else:
    print(f"RSS after warm-up ({warmup} frames) {warm_rss} kB, at the end {end_rss} kB "
          f"({end_rss - warm_rss:+d} kB), highest {peak} kB; margin {margin_kb:.0f} kB")
    if end_rss - warm_rss > margin_kb:
        fail(f"RSS grew {end_rss - warm_rss} kB after the warm-up (margin {margin_kb:.0f} kB)")
sys.exit(1 if problems else 0)
EOF
# A clean stop: SIGTERM, exit 0, nothing on stderr but the stop's own line.
kill -TERM "$SERVER" 2>/dev/null || true
if ! wait "$SERVER"; then
    echo "soak-serve: FAIL: the server did not stop cleanly" >&2
    status=1
fi
SERVER=
if grep -v '^stopping (SIGTERM)' "$SCRATCH/err" | grep -q .; then
    echo "soak-serve: FAIL: the server wrote to stderr:" >&2
    head -20 "$SCRATCH/err" >&2
    status=1
fi
if [ $status -eq 0 ]; then echo "soak-serve: ok"; fi
exit $status
