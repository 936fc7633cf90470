#!/usr/bin/env python3
"""Instron-style (Bluehill CSV) compression files for the batch timing
(`bench/batch.sh`): the layout of the shipped Ecoflex file (metadata lines, then
`Time (s),Compression (mm),Load (N),...` at 10 Hz), each a different silicone cylinder
compressed at 10 mm/min to 20 mm: a stiffening law F = a·(e^{b·δ} − 1) with
a = 5-40 N and b = 0.1-0.25 1/mm, a load-cell offset of ±0.05 N and 0.02 N of noise.
Standard library only, fixed seed.

    python3 bench/make_instron.py OUT_DIR [COUNT]     # default 200 files
"""

import math
import os
import random
import sys


def main():
    out = sys.argv[1]
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    os.makedirs(out, exist_ok=True)
    rng = random.Random(20261122)
    for i in range(count):
        a = rng.uniform(5.0, 40.0)
        b = rng.uniform(0.10, 0.25)
        offset = rng.uniform(-0.05, 0.05)
        rows = 1201
        lines = [
            f"EF_batch_sample_{i + 1}",
            "Compression test;",
            "Cylinder Diameter: 50mm;",
            "Cylinder Height: 30mm;",
            "Speed (mm/min): 10;",
            "Machine: INSTRON 5900;",
            "Load cell: 1kN;",
            "Time (s),Compression (mm),Load (N),Engineering Strain [-],Engineering Stress (kPa)",
        ]
        area_m2 = math.pi * 0.025**2
        for k in range(rows):
            t = 0.1 * k
            d = 10.0 / 60.0 * t + rng.gauss(0.0, 0.002)
            load = a * (math.exp(b * max(d, 0.0)) - 1.0) + offset + rng.gauss(0.0, 0.02)
            strain = -d / 30.0
            stress = -load / area_m2 / 1000.0
            lines.append(f"{t:.6f},{d:.6f},{load:.6f},{strain:.6f},{stress:.6f}")
        with open(os.path.join(out, f"sample_{i + 1:03d}.csv"), "w") as fh:
            fh.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
