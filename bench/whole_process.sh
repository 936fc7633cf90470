#!/usr/bin/env bash
# Whole processes, timed from outside, on the same generated files:
#  1. `host-sim estimate --model hunt-crossley --json` against the plain Python + NumPy
#     reference (bench/estimate_reference.py: np.loadtxt, a threshold contact, the
#     double-stage estimator of bench/reference.py in pure Python) on a 600 s, 1 kHz log
#     (bench/make_log.py): wall time and peak memory of each, median of RUNS, and the ratio;
#  2. the batch: `estimate` and `diagnose` on a folder of 200 Instron-style compression
#     files (bench/make_instron.py), wall time of one run each.
# Needs python3 with NumPy. Prints the parameters of both against the truth (the
# reference's threshold contact biases its exponent; the timing compares the same work:
# read, condition, estimate every sample in contact).
#
#   bash bench/whole_process.sh            # RUNS=3 SECONDS_LOG=600 FILES=200 to change
set -euo pipefail
cd "$(dirname "$0")/.."

runs="${RUNS:-3}"
seconds="${SECONDS_LOG:-600}"
files="${FILES:-200}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

cargo build --release --quiet -p host-sim
bin="${CARGO_TARGET_DIR:-target}/release/host-sim"
python3 bench/make_log.py "$tmp/log.csv" "$seconds"
python3 bench/make_instron.py "$tmp/instron" "$files"

# median wall time [s] and peak RSS [KiB] of RUNS runs of a command (stdout to $tmp/out)
measure() {
  local label="$1"; shift
  for _ in $(seq "$runs"); do
    /usr/bin/time -f "%e %M" -o "$tmp/time" "$@" > "$tmp/out.$label" 2> /dev/null
    cat "$tmp/time"
  done | sort -n | awk -v n="$runs" 'NR == int((n + 1) / 2) { print $1, $2 }'
}

read -r rust_s rust_kib < <(measure rust "$bin" estimate --model hunt-crossley --json "$tmp/log.csv")
read -r py_s py_kib < <(measure python python3 bench/estimate_reference.py "$tmp/log.csv")
echo "log: ${seconds} s at 1 kHz, $(wc -l < "$tmp/log.csv") lines, $(du -h "$tmp/log.csv" | cut -f1)"
echo "host-sim estimate: ${rust_s} s wall, peak ${rust_kib} KiB (median of ${runs})"
echo "python reference:  ${py_s} s wall, peak ${py_kib} KiB (median of ${runs})"
python3 - "$rust_s" "$py_s" "$rust_kib" "$tmp/out.rust" "$tmp/out.python" <<'PY'
import json, sys
rust_s, py_s, rust_kib = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
rust = json.loads(open(sys.argv[4]).read())["parameters"]
py = json.loads(open(sys.argv[5]).read())
truth = {"k": 4.578e4, "lambda": 2.787e5, "n": 1.2}
for name, true in truth.items():
    print(f"{name:>6}: truth {true:.4e}  host-sim {rust[name]:.4e}  python {py[name]:.4e}")
ratio = py_s / rust_s
print(f"ratio python/host-sim: {ratio:.1f}x (target >= 20x: {'met' if ratio >= 20 else 'NOT met'})")
mib = rust_kib / 1024
print(f"peak memory: {mib:.0f} MiB (target <= 64 MiB: {'met' if mib <= 64 else 'NOT met'})")
PY

for command in estimate diagnose; do
  args=(--model hunt-crossley --summary "$tmp/summary-$command")
  [ "$command" = diagnose ] && args=(--out "$tmp/summary-$command")
  start=$(date +%s%N)
  status=0
  "$bin" "$command" "${args[@]}" "$tmp/instron" > /dev/null 2> "$tmp/batch.err" || status=$?
  end=$(date +%s%N)
  echo "batch $command, ${files} Instron-style files: $(( (end - start) / 1000000 )) ms wall (exit ${status}; $(tail -1 "$tmp/batch.err"))"
done
