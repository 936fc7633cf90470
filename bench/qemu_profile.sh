#!/usr/bin/env bash
# Where the Cortex-M4F instructions go: the QEMU firmware run (the one `cargo qemu` makes)
# under `-singlestep -d exec,nochain`, so that QEMU logs the address of every instruction
# it executes; the addresses are counted (through a FIFO: the log would be gigabytes),
# attributed to source lines by llvm-symbolizer with the inlined frames, and summed.
#
# Prints, per call of each:
#   - the functions that ran the most instructions (the whole run: the 1 kHz task and the
#     estimator benchmarks);
#   - the 1 kHz task (the TIM2 handler, everything inlined into it) by the outermost
#     estimator-core source line, i.e. by pipeline step;
#   - the Hunt-Crossley double stage's update by its own source lines.
# Counts are exact (QEMU -icount), per call = total / the number of calls.
#
#   bash bench/qemu_profile.sh        # ≈ 3 min; needs qemu-system-arm, llvm-symbolizer, python3
set -euo pipefail
cd "$(dirname "$0")/.."

elf=target/thumbv7em-none-eabihf/release/firmware
cargo build --release --quiet -p firmware --target thumbv7em-none-eabihf --features qemu
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkfifo "$tmp/exec"
awk -F/ '/^Trace/ {c[$2]++} END {for (k in c) print k, c[k]}' "$tmp/exec" > "$tmp/counts" &
counter=$!
timeout 600 qemu-system-arm -machine netduinoplus2 -nographic -monitor none \
  -semihosting-config enable=on,target=native -icount shift=0,sleep=off -singlestep \
  -d exec,nochain -D "$tmp/exec" -serial "file:$tmp/telemetry.bin" -kernel "$elf" \
  > /dev/null 2> "$tmp/stderr" || true
wait "$counter"
symbolizer="$(command -v llvm-symbolizer || echo "$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-symbolizer")"
awk '{print "0x" $1}' "$tmp/counts" \
  | "$symbolizer" --obj="$elf" --inlining=true --functions=linkage > "$tmp/symbols"

python3 - "$tmp/counts" "$tmp/symbols" <<'PY'
import sys
from collections import Counter

counts = [line.split() for line in open(sys.argv[1])]
blocks = open(sys.argv[2]).read().split("\n\n")
rows = []  # (pc, count, outermost symbol, [(function, file:line:column)] innermost first)
for (pc, count), block in zip(counts, blocks):
    lines = block.strip().split("\n")
    frames = [(lines[i], lines[i + 1]) for i in range(0, len(lines) - 1, 2)]
    rows.append((int(pc, 16), int(count), frames[-1][0], frames))

def line_of(location):
    """'crate/src/file.rs:line' of a 'path:line:column' location."""
    path = location.rsplit(":", 1)[0]
    for root in ("estimator-core/", "firmware/"):
        if root in path:
            return root + path.split(root, 1)[1]
    return path.rsplit("/", 1)[-1]

def calls(symbol):
    """Calls of a function: the count at its lowest address (its entry)."""
    return min((r for r in rows if r[2] == symbol), key=lambda r: r[0])[1]

per_function = Counter()
for _, count, symbol, _ in rows:
    per_function[symbol] += count
print("functions, whole run: instructions per call (calls)")
for symbol, total in per_function.most_common(15):
    n = calls(symbol)
    print(f"  {total / n:8.1f} ({n:>6}) {symbol[:100]}")

task = [r for r in rows if r[2] == "TIM2"]
if task:
    n = calls("TIM2")
    by_step = Counter()
    for _, count, _, frames in task:
        core = [f[1] for f in frames if "estimator-core/" in f[1]]
        by_step[line_of(core[-1]) if core else line_of(frames[0][1])] += count
    print(f"\n1 kHz task (TIM2, {n} calls): {sum(by_step.values()) / n:.1f} per call inline, by outermost core line")
    for where, total in by_step.most_common(20):
        print(f"  {total / n:8.1f} {where}")

def in_double_stage(frames):
    return any("HuntCrossleyEstimator" in f and "update" in f and "SingleStage" not in f
               for f, _ in frames)

hc = [r for r in rows if in_double_stage(r[3])]
if hc:
    n = max(r[1] for r in hc)
    by_line = Counter()
    for _, count, _, frames in hc:
        own = [line_of(f[1]) for f in frames if "hunt_crossley.rs" in f[1]]
        inner = line_of(frames[0][1])
        key = own[0] if own else "?"
        by_line[key if inner == key else f"{key}  [{inner}]"] += count
    print(f"\nHunt-Crossley double stage update (≈ {n} calls): {sum(by_line.values()) / n:.1f} per call, by its own line [innermost]")
    for where, total in sorted(by_line.items(), key=lambda kv: -kv[1])[:25]:
        print(f"  {total / n:8.1f} {where}")
PY
