#!/usr/bin/env python3
"""Issue 32's bar on a set of 14 simulated 300 s logs (docs/monitor.md):
8 with a 5-15 % step in one direction's Coulomb force, 6 change-free,
test motion (ladder, sine) and production motion, drives, rates and
logging conventions drawn from --seed. A log passes when it has exactly
the alarms it should: on a step log one alarm, on Fc of the stepped
direction, with the sign of the step, raised after the step and at most
60 s after it; on a change-free log none.

    python3 host_sim/bench/monitor_heldback.py [--feedid build/bin/feedid] [--seed 32]
"""
import argparse, json, os, random, subprocess, tempfile


def draw(rnd, i, duration_s=300, change_window_s=(100, 220)):
    step = i < 8
    prog = ['production', 'ladder', 'sine', 'production'][i % 4] if step else ['production', 'sine', 'ladder'][i % 3]
    fcp = rnd.uniform(15, 70)
    args = ['--program', prog, '--duration', str(duration_s), '--rate', str(rnd.choice([1000, 2000, 4000])),
            '--force-log', rnd.choice(['held', 'instant', 'averaged']),
            '--velocity-log', rnd.choice(['backward', 'average', 'lowpass']),
            '--mass', '%.2f' % rnd.uniform(50, 180), '--fc-pos', '%.2f' % fcp, '--fc-neg', '%.2f' % (fcp * rnd.uniform(0.85, 1.15)),
            '--sigma-pos', '%.1f' % rnd.uniform(300, 1200), '--sigma-neg', '%.1f' % rnd.uniform(300, 1200),
            '--fs-pos', '%.2f' % rnd.uniform(2, 12), '--fs-neg', '%.2f' % rnd.uniform(2, 12),
            '--vs-pos', '%.4f' % rnd.uniform(0.001, 0.004), '--vs-neg', '%.4f' % rnd.uniform(0.001, 0.004),
            '--force-noise', '%.2f' % rnd.uniform(0.3, 2.0), '--seed', str(rnd.randrange(1, 10 ** 6))]
    change = None
    if step:
        frac = rnd.uniform(0.05, 0.15) * rnd.choice([-1, 1])
        change = {'t': round(rnd.uniform(*change_window_s), 1), 'frac': round(frac, 3), 'dir': rnd.choice(['pos', 'neg'])}
        args += ['--change-time', str(change['t']), '--change-coulomb-fraction', str(change['frac']),
                 '--change-direction', change['dir']]
    return prog, args, change


def verdict(alarms, change):
    if change is None:
        return not alarms, 'none expected'
    if len(alarms) != 1:
        return False, '%d alarms' % len(alarms)
    a = alarms[0]
    ok = (a['parameter'] == 'fc' and a['direction'] == change['dir'] and (a['change'] > 0) == (change['frac'] > 0)
          and change['t'] <= a['raised_t_s'] <= change['t'] + 60.0)
    return ok, 'raised %.0f s after' % (a['raised_t_s'] - change['t'])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--feedid', default='build/bin/feedid')
    ap.add_argument('--seed', type=int, default=32)
    o = ap.parse_args()
    rnd = random.Random(o.seed)
    passed = 0
    print('| log | program | change | alarms | pass |')
    print('|---|---|---|---|---|')
    with tempfile.TemporaryDirectory() as tmp:
        log, out = os.path.join(tmp, 'log.csv'), os.path.join(tmp, 'mon.json')
        for i in range(14):
            prog, args, change = draw(rnd, i)
            subprocess.run([o.feedid, 'simulate'] + args + ['--out', log], check=True, capture_output=True)
            subprocess.run([o.feedid, 'monitor', '--in', log, '--json', out], capture_output=True)
            alarms = json.load(open(out))['alarms']
            ok, why = verdict(alarms, change)
            passed += ok
            ch = 'none' if change is None else 'Fc %s %+.1f %% at %.1f s' % (change['dir'], 100 * change['frac'], change['t'])
            al = '; '.join('%s %s %+.1f %% from %.0f s, raised %.0f s' % (a['parameter'], a['direction'], a['change_pct'],
                                                                         a['t_s'], a['raised_t_s']) for a in alarms) or 'none'
            print('| %d | %s | %s | %s | %s |' % (i + 1, prog, ch, al, ('yes' if ok else 'NO') + ' (' + why + ')'), flush=True)
    print('\n**%d of 14 logs right** (seed %d)' % (passed, o.seed))


if __name__ == '__main__':
    main()
