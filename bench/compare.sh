#!/usr/bin/env bash
# Rust core vs the pure-Python reference of the double-stage Hunt-Crossley estimator:
# the same CSV of in-contact samples through both, final k, λ, n compared (within 1 %),
# and the ratio of their samples per second. Only the estimation loops are timed; both do
# the same per-sample work (prediction, both RLS stages, residual variances, parameters in
# SI). Fails only if the parameters disagree.
#
#   bash bench/compare.sh            # 120 s of samples at 1 kHz (DATA_SECONDS to change)
set -euo pipefail
cd "$(dirname "$0")/.."

data_seconds="${DATA_SECONDS:-120}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

cargo build --release --quiet -p host-sim --example hc_throughput
bin=target/release/examples/hc_throughput
"$bin" --write-csv "$tmp/samples.csv" --seconds "$data_seconds"

rust="$("$bin" "$tmp/samples.csv")"
python="$(python3 bench/reference.py "$tmp/samples.csv")"
echo "rust:   $rust"
echo "python: $python"

python3 - "$rust" "$python" <<'PY'
import json, sys
rust, python = (json.loads(a) for a in sys.argv[1:3])
worst = 0.0
for name in ("k", "lambda", "n"):
    r, p = rust[name], python[name]
    rel = abs(r - p) / abs(p)
    worst = max(worst, rel)
    print(f"{name:>6}: rust {r:.6e}  python {p:.6e}  difference {100 * rel:.4f} %")
ratio = rust["samples_per_s"] / python["samples_per_s"]
print(f"samples/s: rust {rust['samples_per_s']:.4g}, python {python['samples_per_s']:.4g}")
print(f"ratio rust/python: {ratio:.0f}x (target >= 100x: {'met' if ratio >= 100 else 'NOT met'})")
if worst > 0.01:
    sys.exit(f"final parameters differ by {100 * worst:.3f} % (> 1 %)")
PY
