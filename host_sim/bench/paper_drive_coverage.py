#!/usr/bin/env python3
"""Coverage on the seed paper's drive (Table 1: vs = 1.4e-4 m/s, 14 velocity
quanta at 10 nm and 1 kHz), a drive `feedid coverage` does not hold: N
simulated traces of the speed ladder, seeds 1..N, the velocity column the
backward difference of the logged position (the simulator's default);
how often each parameter lies within 1.96 of its reported error of the
truth, and the mean and RMS of error / error.

    python3 host_sim/bench/paper_drive_coverage.py [--feedid build/bin/feedid] [--seeds 20] [--duration 60]
"""
import argparse, json, os, subprocess, tempfile

PAPER = {'mass': 98.99, 'sigma-pos': 705.05, 'fc-pos': 25.79, 'fs-pos': 7.48, 'vs-pos': 1.44e-4,
         'sigma-neg': 759.82, 'fc-neg': 26.96, 'fs-neg': 7.59, 'vs-neg': 1.43e-4}
NAMES = ['m', 'sigma+', 'Fc+', 'Fs+', 'vs+', 'sigma-', 'Fc-', 'Fs-', 'vs-']


def z_scores(d):
    z = [(d['m'] - PAPER['mass']) / d['m_se']]
    for side in ('pos', 'neg'):
        for k in ('sigma', 'fc', 'fs', 'vs'):
            z.append((d[side][k] - PAPER[k + '-' + side]) / d[side][k + '_se'])
    return z


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--feedid', default='build/bin/feedid')
    ap.add_argument('--seeds', type=int, default=20)
    ap.add_argument('--duration', type=float, default=60.0)
    o = ap.parse_args()
    drive = [a for k, v in PAPER.items() for a in ('--' + k, repr(v))]
    rows, origins = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        trace, out = os.path.join(tmp, 'paper.csv'), os.path.join(tmp, 'id.json')
        for seed in range(1, o.seeds + 1):
            subprocess.run([o.feedid, 'simulate', *drive, '--rate', '1000', '--slowest-speed', '5e-5',
                            '--duration', repr(o.duration), '--seed', str(seed), '--out', trace],
                           check=True, capture_output=True)
            subprocess.run([o.feedid, 'identify', '--in', trace, '--json', out], check=True, capture_output=True)
            with open(out) as f:
                d = json.load(f)
            rows.append(z_scores(d))
            origin = d['input']['velocity'].split(':')[0].split(';')[0]
            origins[origin] = origins.get(origin, 0) + 1
    n = len(rows)
    print(f'{n} traces of {o.duration:g} s; velocity: ' + ', '.join(f'{k} {v}' for k, v in origins.items()))
    print(f'{"parameter":<10} {"coverage":>9} {"mean z":>8} {"RMS z":>7}')
    for j, name in enumerate(NAMES):
        col = [r[j] for r in rows]
        cover = sum(abs(z) <= 1.96 for z in col) / n
        mean = sum(col) / n
        rms = (sum(z * z for z in col) / n) ** 0.5
        print(f'{name:<10} {100 * cover:>8.0f}% {mean:>+8.2f} {rms:>7.2f}')


if __name__ == '__main__':
    main()
