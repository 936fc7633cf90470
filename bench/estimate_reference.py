#!/usr/bin/env python3
"""What a researcher would write instead of `host-sim estimate --model hunt-crossley`:
NumPy reads the log, a threshold finds contact, and the double-stage Hunt-Crossley
estimator of `bench/reference.py` runs in plain Python over the samples in contact.

Whole process, for `bench/whole_process.sh`. Input: the project's CSV
(`time_s,position_m,force_n`, position increasing into the material, starting out of
contact). Steps:
- `np.loadtxt` the three columns (by header name);
- force offset: the mean of the first 100 ms (the log starts out of contact);
- contact: offset-corrected force above 8 σ of that stretch; the contact position is the
  position at the first onset; δ = position − contact position;
- δ̇: `np.gradient` of the position;
- the estimator steps over every in-contact sample with δ > 0.

Prints one JSON line: k [N/m^n], lambda [N·s/m^(n+1)], n, samples in contact.

    python3 bench/estimate_reference.py LOG.csv
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference import HuntCrossley  # noqa: E402


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: estimate_reference.py LOG.csv")
    path = sys.argv[1]
    with open(path) as fh:
        header = fh.readline().strip().split(",")
    cols = [header.index(c) for c in ("time_s", "position_m", "force_n")]
    t, x, f = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, unpack=True)
    start = t < t[0] + 0.1
    offset = f[start].mean()
    sigma = f[start].std()
    force = f - offset
    contact = force > 8.0 * sigma
    x_c = x[np.argmax(contact)]
    depth = x - x_c
    rate = np.gradient(x, t)
    estimator = HuntCrossley()
    steps = 0
    for d, v, fc, c in zip(depth.tolist(), rate.tolist(), force.tolist(), contact.tolist()):
        if c and d > 0.0:
            estimator.step(d, v, fc)
            steps += 1
    k, lam, n = estimator.parameters_si()
    print(json.dumps({"k": k, "lambda": lam, "n": n, "samples_in_contact": steps}))


if __name__ == "__main__":
    main()
