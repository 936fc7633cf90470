#!/usr/bin/env python3
"""A long 1 kHz log in the project's format (`time_s,position_m,force_n`) for the
whole-process comparison (`bench/whole_process.sh`).

The paper's plastic layer (Hunt-Crossley, eq. 3: k = 4.578e4 N/m^1.2,
λ = 2.787e5 N·s/m^2.2, n = 1.2) tapped at 2 Hz: the tool starts 0.3 mm out of contact,
presses to between 0.4 and 1.2 mm (the depth varies slowly) and lifts off each cycle;
force offset 0.15 N, 20 mN Gaussian force noise, 1 µm position quantisation. NumPy only,
fixed seed, so the file is reproducible.

    python3 bench/make_log.py OUT.csv [SECONDS]      # default 600 s
"""

import sys

import numpy as np

K, LAMBDA, N = 4.578e4, 2.787e5, 1.2


def main():
    out = sys.argv[1]
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 600.0
    t = np.arange(int(round(seconds * 1000.0)) + 1) * 1.0e-3
    rng = np.random.default_rng(20261122)
    depth_max = 0.8e-3 + 0.4e-3 * np.sin(2.0 * np.pi * 0.013 * t)
    # position into the material; contact surface at 0, tool 0.3 mm out at the top
    phase = np.where(t < 1.0, 0.0, 0.5 - 0.5 * np.cos(2.0 * np.pi * 2.0 * (t - 1.0)))
    x = -0.3e-3 + phase * (depth_max + 0.3e-3)
    v = np.gradient(x, t)
    d = np.clip(x, 0.0, None)
    f = np.where(d > 0.0, K * d**N + LAMBDA * d**N * v, 0.0)
    f = np.clip(f, 0.0, None)
    force = f + 0.15 + 0.02 * rng.standard_normal(t.size)
    position = np.round(x * 1.0e6) * 1.0e-6
    np.savetxt(
        out,
        np.column_stack([t, position, force]),
        delimiter=",",
        header="time_s,position_m,force_n",
        comments="",
        fmt=["%.3f", "%.6e", "%.6f"],
    )


if __name__ == "__main__":
    main()
