#!/usr/bin/env python3
"""Coverage of identify's gravity term (host_sim/identify/gravity.hpp): N
simulated arms, the default drive's ladder read as an arm (travel x 20 in
rad) with G cos(q - q0) added to its force, seeds 1..N; how often G and q0
lie within 1.96 of their reported errors of the truth.

    python3 host_sim/bench/gravity_coverage.py [--feedid build/bin/feedid] [--arms 12] [--G 30] [--q0 0.4]
"""
import argparse, json, os, subprocess, tempfile

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--feedid', default='build/bin/feedid')
    ap.add_argument('--arms', type=int, default=12)
    ap.add_argument('--G', type=float, default=30.0)
    ap.add_argument('--q0', type=float, default=0.4)
    o = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        raw, arm, out = (os.path.join(tmp, n) for n in ('raw.csv', 'arm.csv', 'id.json'))
        for seed in range(1, o.arms + 1):
            subprocess.run([o.feedid, 'simulate', '--seed', str(seed), '--out', raw], check=True, capture_output=True)
            d = np.genfromtxt(raw, delimiter=',', names=True)
            x = d['x'] * 20
            np.savetxt(arm, np.c_[d['t'], x, d['v'] * 20, d['u'] + o.G * np.cos(x - o.q0)], delimiter=',',
                       header='t,x,v,u', comments='', fmt='%.17g')
            subprocess.run([o.feedid, 'identify', '--in', arm, '--axis', 'rotary', '--gravity', 'angle', '--json', out],
                           check=True, capture_output=True)
            g = json.load(open(out))['gravity']
            rows.append((g['G'], g['G_se'], g['angle0_rad'], g['angle0_se_rad']))
            print('%2d  G %.4f +- %.4f  q0 %.5f +- %.5f' % ((seed,) + rows[-1]), flush=True)
    r = np.array(rows)
    for name, v, se, truth in (('G', r[:, 0], r[:, 1], o.G), ('q0', r[:, 2], r[:, 3], o.q0)):
        z = (v - truth) / se
        print('%s: mean %.5g, spread %.2g, mean error %.2g; within 1.96 errors in %d of %d (mean z %.2f)'
              % (name, v.mean(), v.std(), se.mean(), int((abs(z) < 1.96).sum()), len(z), z.mean()))


if __name__ == '__main__':
    main()
