#!/usr/bin/env python3
"""Coverage of the monitor's per-epoch standard errors (issue 32): simulated
300 s logs with known truth (drives, noise, rates and logging conventions
drawn per log; production, sine and ladder motion in turn); for every epoch
and every parameter it compared (identifiable; m, sigma and Fc, then Fs
and vs), whether truth lies within
estimate +- 1.96 se. Usage:
    python3 host_sim/bench/monitor_coverage.py build/bin/feedid LOGS SEED TMPDIR
"""
import json, subprocess, sys, os, math, random
B = sys.argv[1]; n = int(sys.argv[2]); off = int(sys.argv[3]); tmp = sys.argv[4]
extra = sys.argv[5:]
progs = ['production', 'sine', 'ladder']
tot = {}; hit = {}; skipped = 0; epochs = 0
for i in range(n):
    rnd = random.Random(1000 * off + i)
    prog = progs[i % 3]
    rate = [1000, 2000, 4000][rnd.randrange(3)]
    fl = ['held', 'instant', 'averaged'][rnd.randrange(3)]
    vl = ['backward', 'average', 'lowpass'][rnd.randrange(3)]
    m = rnd.uniform(40, 200); fcp = rnd.uniform(10, 90); fcn = fcp * rnd.uniform(0.8, 1.2)
    sp = rnd.uniform(200, 1500); sn = sp * rnd.uniform(0.9, 1.1)
    args = [B, 'simulate', '--program', prog, '--duration', '300', '--seed', str(off * 100 + i), '--rate', str(rate),
            '--force-log', fl, '--velocity-log', vl, '--mass', str(m), '--fc-pos', str(fcp), '--fc-neg', str(fcn),
            '--sigma-pos', str(sp), '--sigma-neg', str(sn), '--force-noise', str(rnd.uniform(0.2, 3)), '--process-noise', str(rnd.choice([0, 0, 0.5, 2])), '--fs-pos', str(rnd.uniform(2, 20)), '--fs-neg', str(rnd.uniform(2, 20)), '--vs-pos', str(rnd.uniform(0.0005, 0.005)), '--vs-neg', str(rnd.uniform(0.0005, 0.005)), '--accel', str(rnd.uniform(0.5, 3)), '--fastest-speed', str(rnd.uniform(0.05, 0.3)), '--out', tmp + '/c.csv', '--truth', tmp + '/c.json']
    subprocess.run(args, capture_output=True, check=True)
    subprocess.run([B, 'monitor', '--in', tmp + '/c.csv', '--json', tmp + '/cm.json'] + extra, capture_output=True)
    tr = json.load(open(tmp + '/c.json')); mj = json.load(open(tmp + '/cm.json'))
    for ep in mj['epochs']:
        epochs += 1
        if 'error' in ep: skipped += 1; continue
        items = [('m', ep['m'], ep['m_se'], ep['m_identifiable'], tr['m'])]
        for d in ('pos', 'neg'):
            for k in ('sigma', 'fc', 'fs', 'vs'):
                items.append((k + d, ep[d][k], ep[d][k + '_se'], ep[d]['identifiable'][k], tr[d][k]))
        for name, v, se, ok, truth in items:
            if not ok: continue
            key = (prog, name)
            tot[key] = tot.get(key, 0) + 1
            h = abs(v - truth) <= 1.96 * se
            hit[key] = hit.get(key, 0) + h
            if not h and abs(v - truth) > 5 * se and '-v' in os.environ.get('COVV', ''):
                print('  miss', i, prog, ep['t_start_s'], name, v, se, truth)
    print(i, prog, rate, fl, vl, file=sys.stderr)
print('epochs', epochs, 'skipped', skipped)
main = ['m', 'sigmapos', 'sigmaneg', 'fcpos', 'fcneg']
stribeck = ['fspos', 'fsneg', 'vspos', 'vsneg']
for p in progs:
    for name in main + stribeck:
        k = (p, name)
        if k in tot: print('%-11s %-9s %4d/%4d = %.1f %%' % (p, name, hit[k], tot[k], 100.0 * hit[k] / tot[k]))
T = sum(v for k, v in tot.items() if k[1] in main); H = sum(v for k, v in hit.items() if k[1] in main)
print('all %d/%d = %.1f %%' % (H, T, 100.0 * H / T))
T = sum(tot.values()); H = sum(hit.values()); print('all with Fs and vs %d/%d = %.1f %%' % (H, T, 100.0 * H / T))
