#!/usr/bin/env python3
"""Pure-Python reference of the double-stage Hunt-Crossley estimator.

The alternative a researcher would write: plain Python, no NumPy, following the
estimator core (estimator-core/src/hunt_crossley.rs, rls.rs) step for step, so that its
final parameters can be compared with the Rust core's and its speed measured against it.

Algorithm (Biagiotti & Melchiorri, eqs. 25-37, with the core's departures):
- internal units mm and N (the core's default Scaling);
- Γ1: RLS on y1 = F, φ1 = [δ^n̂, δ^n̂·δ̇] for θ1 = [k, λ], P(0) = 1e3·I;
- Γ2: RLS with an intercept on y2 = ln(F/(k̂ + λ̂·δ̇)) = c + n·ln δ, θ2 = [c, n],
  θ2(0) = [0, 1], P(0) = I; n̂ projected into [0.5, 3];
- forgetting β = 0.9995, with start-up forgetting 1 − β_s(h) = 0.01·(1 − 1/1000)^h per
  update of each stage; anti-wind-up bound trace(P) ≤ c·N; P kept exactly symmetric and
  reset to c·I if it loses positive definiteness;
- guards: δ ≤ 20 µm skips the sample, F ≤ 0.2 N or k̂ + λ̂·δ̇ ≤ 0 skips Γ2;
- per sample, like the core's `step`: the a-priori force prediction, the running
  residual variance of each stage (for standard errors) and the parameters in SI.

Input: CSV with header `depth_m,depth_rate_m_per_s,force_n` (in-contact samples, SI).
Output: one JSON line with k [N/m^n], lambda [N·s/m^(n+1)], n, the number of samples and
the samples per second of the estimation loop (parsing excluded).

    python3 bench/reference.py samples.csv
"""

import csv
import json
import math
import sys
import time

LENGTH_M = 1.0e-3  # internal length unit [m]
FORCE_N = 1.0  # internal force unit [N]
BETA = 0.9995
STARTUP_FORGETTING = 0.99
STARTUP_SAMPLES = 1000.0
MIN_DEPTH_M = 20.0e-6
MIN_FORCE_N = 0.2
MIN_EXPONENT = 0.5
MAX_EXPONENT = 3.0
FLT_MIN = 1.1754943508222875e-38  # f32::MIN_POSITIVE
RESIDUAL_VARIANCE_RATE = 1.0e-3


class Rls2:
    """Recursive least squares for two parameters (eqs. 20-23) with the core's guards."""

    def __init__(self, c, theta0):
        self.c = c
        self.theta = list(theta0)
        self.p = [[c, 0.0], [0.0, c]]
        self.max_trace = 1.0 * c * 2
        self.startup_gap = 1.0 - STARTUP_FORGETTING
        self.startup_decay = 1.0 - 1.0 / max(STARTUP_SAMPLES, 1.0)
        self.residual_variance = 0.0

    def reset_covariance(self):
        self.p = [[self.c, 0.0], [0.0, self.c]]

    def update(self, phi0, phi1, y, beta):
        if not (math.isfinite(y) and math.isfinite(phi0) and math.isfinite(phi1)):
            return
        beta = min(max(min(beta, 1.0 - self.startup_gap), FLT_MIN), 1.0)
        self.startup_gap *= self.startup_decay
        (p00, p01), (_, p11) = self.p
        pphi0 = p00 * phi0 + p01 * phi1
        pphi1 = p01 * phi0 + p11 * phi1
        denom = beta + phi0 * pphi0 + phi1 * pphi1
        th0, th1 = self.theta
        prior = y - (phi0 * th0 + phi1 * th1)
        if not (math.isfinite(denom) and denom > 0.0):
            self.reset_covariance()
            return
        q0 = pphi0 / denom
        q1 = pphi1 / denom
        new0 = th0 + q0 * prior
        new1 = th1 + q1 * prior
        n00 = p00 - q0 * pphi0
        n01 = p01 - q0 * pphi1
        n11 = p11 - q1 * pphi1
        trace = n00 + n11
        beta_eff = beta
        if trace > self.max_trace * beta:
            beta_eff = min(trace / self.max_trace, 1.0)
        n00 /= beta_eff
        n01 /= beta_eff
        n11 /= beta_eff
        if positive_definite(n00, n01, n11):
            self.p = [[n00, n01], [n01, n11]]
        else:
            self.reset_covariance()
        if math.isfinite(new0) and math.isfinite(new1):
            self.theta = [new0, new1]
            post = y - (phi0 * new0 + phi1 * new1)
            self.residual_variance += RESIDUAL_VARIANCE_RATE * (
                post * post - self.residual_variance
            )
        else:
            self.reset_covariance()


def positive_definite(p00, p01, p11):
    """LDLᵀ pivots positive relative to the diagonal, as the core checks."""
    if not all(math.isfinite(v) for v in (p00, p01, p11)):
        return False
    d0 = p00
    if not (d0 > 1.0e-6 * abs(p00) and d0 > 0.0):
        return False
    l10 = p01 / d0
    d1 = p11 - l10 * l10 * d0
    return d1 > 1.0e-6 * abs(p11) and d1 > 0.0


class HuntCrossley:
    """The double-stage estimator: Γ1 for [k, λ] given n̂, Γ2 for [c, n] given k̂, λ̂."""

    def __init__(self):
        self.gamma1 = Rls2(1.0e3, [0.0, 0.0])
        self.gamma2 = Rls2(1.0, [0.0, 1.0])
        self.min_depth = MIN_DEPTH_M / LENGTH_M
        self.min_force = MIN_FORCE_N / FORCE_N

    def step(self, depth_m, rate_m_per_s, force_n):
        """One sample; returns (SI parameters, a-priori predicted force [N])."""
        d = depth_m / LENGTH_M
        v = rate_m_per_s / LENGTH_M
        f = force_n / FORCE_N
        if not (math.isfinite(d) and math.isfinite(v) and math.isfinite(f)):
            return self.parameters_si(), 0.0
        if d <= self.min_depth:
            return self.parameters_si(), 0.0
        ln_d = math.log(d)
        d_pow_n = math.exp(self.gamma2.theta[1] * ln_d)
        k, lam = self.gamma1.theta
        predicted = d_pow_n * k + d_pow_n * v * lam
        self.gamma1.update(d_pow_n, d_pow_n * v, f, BETA)
        k, lam = self.gamma1.theta
        impedance = k + lam * v
        if f > self.min_force and impedance > 0.0:
            y2 = math.log(f) - math.log(impedance)
            self.gamma2.update(1.0, ln_d, y2, BETA)
            n = self.gamma2.theta[1]
            if n < MIN_EXPONENT or n > MAX_EXPONENT:
                self.gamma2.theta[1] = min(max(n, MIN_EXPONENT), MAX_EXPONENT)
        return self.parameters_si(), predicted * FORCE_N

    def parameters_si(self):
        """(k [N/m^n], λ [N·s/m^(n+1)], n)."""
        k, lam = self.gamma1.theta
        n = self.gamma2.theta[1]
        l_pow_n = math.exp(n * math.log(LENGTH_M))
        return k * FORCE_N / l_pow_n, lam * FORCE_N / (l_pow_n * LENGTH_M), n


def read_samples(path):
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return [
            (float(r["depth_m"]), float(r["depth_rate_m_per_s"]), float(r["force_n"]))
            for r in reader
        ]


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: reference.py SAMPLES.csv")
    samples = read_samples(sys.argv[1])
    estimator = HuntCrossley()
    start = time.perf_counter()
    for depth_m, rate, force_n in samples:
        estimator.step(depth_m, rate, force_n)
    seconds = time.perf_counter() - start
    k, lam, n = estimator.parameters_si()
    print(
        json.dumps(
            {
                "implementation": "python",
                "k": k,
                "lambda": lam,
                "n": n,
                "samples": len(samples),
                "seconds": seconds,
                "samples_per_s": len(samples) / seconds,
            }
        )
    )


if __name__ == "__main__":
    main()
