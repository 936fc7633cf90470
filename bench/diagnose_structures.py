#!/usr/bin/env python3
"""A quick check of `diagnose` on motions its hidden-effect sweep does not make: a
Kelvin-Voigt material with one hidden effect (or none) under four recording structures,
20 s at 1 kHz each: sine pressing that begins and stays in contact, taps with lift-off,
load/unload ramps at three speeds, ramp-and-holds (3 s). Inertia logs are 6-9 Hz taps and
6-9 Hz sine pressing only, where the acceleration is large. Noise 0.5 % of the force range,
white on even seeds and AR(1) (ρ = 0.9) on odd ones, 12-bit force quantisation, 1 µm
encoder, position axis reversed on every third seed, 0.3 N offset. NumPy only.

    python3 bench/diagnose_structures.py [SEEDS_PER_CASE] [path/to/host-sim] [pairs]

Prints one line per log (structure, hidden effect, seed, effects added, final NRMSE) and
a count per structure and effect: hidden effect named first / nothing added. With
`pairs`, six pairs of hidden effects instead (seeds from 9100; the pairs with a mass on
the taps only, where a mass is identifiable), counted as both found / an effect added
that was not hidden.
"""
import json, math, os, subprocess, sys
import numpy as np

DT = 1e-3
B = sys.argv[2] if len(sys.argv) > 2 else 'target/release/host-sim'

def motion(kind, rng, T):
    t = np.arange(int(T / DT)) * DT
    if kind == 'sine_in_contact':      # begins and stays in contact
        f = [rng.uniform(0.3, 1.5), rng.uniform(2.0, 4.0)]
        x = 1.5e-3 + 0.6e-3 * np.sin(2*np.pi*f[0]*t) + 0.3e-3 * np.sin(2*np.pi*f[1]*t + 1.0)
    elif kind == 'taps':               # lift-off each cycle
        f = rng.uniform(1.0, 3.0)
        x = -0.4e-3 + 1.0e-3 * (1.5 - 0.5*np.cos(2*np.pi*0.07*t)) * (0.5 - 0.5*np.cos(2*np.pi*f*t))
    elif kind == 'ramps':              # load/unload at three speeds, free space between
        x = []
        for v in (0.5e-3, 2e-3, 6e-3):
            n = int(2.3e-3 / v / DT)
            up = -0.3e-3 + v * DT * np.arange(n)
            x += list(up) + list(up[::-1]) + [-0.3e-3] * 200
        x = np.array(x); t = np.arange(len(x)) * DT
    elif kind == 'ramp_hold':          # ramp, 3 s hold, release, repeated
        x = []
        for depth in (1.2e-3, 2.0e-3):
            n = int((depth + 0.3e-3) / 3e-3 / DT)
            up = -0.3e-3 + 3e-3 * DT * np.arange(n)
            x += list(up) + [up[-1]] * 3000 + list(up[::-1]) + [-0.3e-3] * 500
        x = np.array(x); t = np.arange(len(x)) * DT
    return t, x

def force(x, effect, rng, p):
    S = set(effect.split('+'))   # one effect, or a pair joined by '+'
    v = np.gradient(x, DT); a = np.gradient(v, DT)
    kappa, lam = p['kappa'], p['lambda']
    d = np.clip(x, 0, None); c = d > 0
    if 'power_law_stiffness' in S:
        e = p['k'] * d ** p['n']
    else:
        e = kappa * d
    f = e + lam * v * c
    if 'depth_dependent_damping' in S:
        f = e + p['lam2'] * d ** 1.0 * v
    if 'relaxation' in S:
        alpha = 1 - math.exp(-p['nu'] * DT); y = 0.0; out = np.empty_like(e)
        for i, u in enumerate(e):
            y += alpha * (u - y); out[i] = y
        f = f - p['frac'] * out * c
    if 'inertia' in S:
        f = f + p['m'] * a * c
    if 'time_delay' in S:
        k = int(round(p['delay'] / DT)); f = np.concatenate([np.zeros(k), f[:-k]])
    return np.clip(f, 0, None) * c if 'time_delay' not in S else np.clip(f, 0, None)

def make(kind, effect, seed, path):
    rng = np.random.default_rng(seed)
    T = 20.0
    t, x = motion(kind, rng, T)
    p = dict(kappa=rng.uniform(3e3, 1e4), **{'lambda': rng.uniform(5, 30)}, k=rng.uniform(1e5, 1e6), n=rng.uniform(1.3, 1.8),
             lam2=rng.uniform(1e4, 5e4), nu=rng.uniform(0.5, 3), frac=rng.uniform(0.2, 0.5), m=rng.uniform(0.5, 2.0), delay=rng.uniform(0.004, 0.01))
    if 'inertia' in effect.split('+'):
        # fast taps: inertia needs acceleration
        f = rng.uniform(6.0, 9.0); t = np.arange(int(T/DT))*DT
        x = -0.2e-3 + 1.2e-3 * (0.5 - 0.5*np.cos(2*np.pi*f*t)) if kind != 'sine_in_contact' else 1.0e-3 + 0.4e-3*np.sin(2*np.pi*f*t)
    f = force(x, effect, rng, p)
    rngn = np.random.default_rng(seed + 1000)
    sigma = 0.005 * (f.max() - f.min())
    if seed % 2:   # AR(1) coloured noise with the same variance
        w = rngn.standard_normal(len(f)); n = np.empty_like(w); n[0] = w[0]
        for i in range(1, len(w)): n[i] = 0.9 * n[i-1] + math.sqrt(1 - 0.81) * w[i]
    else:
        n = rngn.standard_normal(len(f))
    lsb = 1.2 * f.max() / 4096
    fm = np.round((f + 0.3 + sigma * n) / lsb) * lsb
    sign = -1 if seed % 3 == 0 else 1
    xm = sign * np.round(x * 1e6) * 1e-6
    np.savetxt(path, np.column_stack([t, xm, fm]), delimiter=',', header='time_s,position_m,force_n', comments='', fmt=['%.4f', '%.7e', '%.6e'])
    return p

rows = []
PAIRS = len(sys.argv) > 3 and sys.argv[3] == 'pairs'
effects = ['none', 'power_law_stiffness', 'depth_dependent_damping', 'relaxation', 'inertia', 'time_delay']
if PAIRS:
    effects = ['power_law_stiffness+relaxation', 'power_law_stiffness+depth_dependent_damping',
               'relaxation+time_delay', 'power_law_stiffness+time_delay', 'inertia+relaxation',
               'inertia+power_law_stiffness']
kinds = ['sine_in_contact', 'taps', 'ramps', 'ramp_hold']
import tempfile
WORK = tempfile.mkdtemp(prefix='diagnose-structures-')
for kind in kinds:
    for effect in effects:
        if 'inertia' in effect.split('+') and (kind in ('ramps', 'ramp_hold') or PAIRS and kind != 'taps'):
            continue  # constant speed (or one sine in contact): a mass is not identifiable
        for seed in range(int(sys.argv[1]) if len(sys.argv) > 1 else 3):
            path = f'{WORK}/{kind}-{effect}-{seed}.csv'
            p = make(kind, effect, seed + (9100 if PAIRS else 7000), path)
            r = subprocess.run([B, 'diagnose', path, '--json', '--out', f'{WORK}/out-{kind}-{effect}-{seed}'], capture_output=True, text=True)
            if r.returncode:
                rows.append((kind, effect, seed, 'ERROR ' + r.stderr.strip().splitlines()[-1][:100])); continue
            d = json.loads(r.stdout)
            added = d.get('effects_added', [])
            rows.append((kind, effect, seed, added, round(d['nrmse_percent_final'], 3)))
            print(*rows[-1], flush=True)
print('\nstructure          hidden                    ' + ('both found / an effect not hidden added' if PAIRS else 'right first (or nothing added for none)'))
for kind in kinds:
    for effect in effects:
        rs = [r for r in rows if r[0] == kind and r[1] == effect]
        if not rs:
            continue
        if PAIRS:
            hidden = set(effect.split('+'))
            ok = sum(1 for r in rs if isinstance(r[3], list) and hidden <= set(r[3]))
            extra = sum(1 for r in rs if isinstance(r[3], list) and set(r[3]) - hidden)
            print(f'{kind:18} {effect:45} both {ok}/{len(rs)}, extra {extra}')
            continue
        ok = sum(1 for r in rs if isinstance(r[3], list) and ((effect == 'none' and not r[3]) or (r[3][:1] == [effect])))
        print(f'{kind:18} {effect:25} {ok}/{len(rs)}')
