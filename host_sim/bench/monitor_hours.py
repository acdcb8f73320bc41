#!/usr/bin/env python3
"""Issue 32's figures: false alarms per 1000 machine-hours and the delay to a
Coulomb step's alarm, from long simulated logs (docs/monitor.md).

Logs of --log-minutes each, drawn as monitor_heldback.py draws its 300 s
logs (drives, noise, rates 1-4 kHz, force and velocity logging conventions,
production / ladder / sine motion), half of them change-free and half with
a 5-15 % step in one direction's Coulomb force at a time drawn in the middle
of the log. Every hour before a step, and every hour of a change-free log,
is watched change-free time: an alarm there is a false alarm. After a step,
the delay is that to the first alarm on Fc of the stepped direction with the
step's sign.

    python3 host_sim/bench/monitor_hours.py [--feedid build/bin/feedid] [--hours 100] [--log-minutes 30] [--seed 1] [--jobs 2]

Progress goes to stderr; the summary (Markdown) to stdout.
"""
import argparse, json, math, os, random, subprocess, sys, tempfile
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from monitor_heldback import draw  # noqa: E402  (one rule for what a log is)


def run_log(feedid, tmp, k, prog, args, change):
    log, out = os.path.join(tmp, 'log%d.csv' % k), os.path.join(tmp, 'mon%d.json' % k)
    try:
        subprocess.run([feedid, 'simulate'] + args + ['--out', log], check=True, capture_output=True)
        subprocess.run([feedid, 'monitor', '--in', log, '--json', out], check=True, capture_output=True)
        with open(out) as f:
            alarms = json.load(f)['alarms']
    finally:
        for p in (log, out):
            if os.path.exists(p):
                os.remove(p)
    return prog, args, change, alarms


def judge(duration_s, change, alarms):
    """(change-free hours, false alarms there, delay s or None, wrong alarms after the step)."""
    t_step = change['t'] if change else duration_s
    false = [a for a in alarms if a['raised_t_s'] < t_step]
    if not change:
        return duration_s / 3600.0, false, None, []
    right = [a for a in alarms if a['raised_t_s'] >= t_step and a['parameter'] == 'fc' and
             a['direction'] == change['dir'] and (a['change'] > 0) == (change['frac'] > 0)]
    wrong = [a for a in alarms if a['raised_t_s'] >= t_step and a not in right]
    delay = min(a['raised_t_s'] for a in right) - t_step if right else None
    return t_step / 3600.0, false, delay, wrong


def quantile(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(math.ceil(q * len(xs))) - 1)] if xs else float('nan')


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--feedid', default='build/bin/feedid')
    ap.add_argument('--hours', type=float, default=100.0)
    ap.add_argument('--log-minutes', type=float, default=30.0)
    ap.add_argument('--seed', type=int, default=1)
    ap.add_argument('--jobs', type=int, default=2)
    o = ap.parse_args()
    duration = int(o.log_minutes * 60)
    n = int(math.ceil(o.hours * 60 / o.log_minutes))
    rnd = random.Random(o.seed)
    logs = []
    for k in range(n):
        step = k % 2 == 0
        i = (k // 2) % 8 if step else 8 + (k // 2) % 6
        logs.append(draw(rnd, i, duration, (0.25 * duration, 0.75 * duration)))
    free_h, false, delays, missed, wrong = 0.0, [], [], [], []
    by_prog = {}
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(o.jobs) as pool:
        futures = [pool.submit(run_log, o.feedid, tmp, k, *log) for k, log in enumerate(logs)]
        for k, fut in enumerate(futures):
            prog, args, change, alarms = fut.result()
            h, fa, delay, wr = judge(duration, change, alarms)
            free_h += h
            false += [(k, prog, a) for a in fa]
            wrong += [(k, prog, a) for a in wr]
            if change:
                (delays if delay is not None else missed).append((delay, k, prog, change))
                if delay is not None:
                    by_prog.setdefault(prog, []).append(delay)
            print('log %d/%d %s %s: %d alarms' % (k + 1, n, prog, 'step' if change else 'free', len(alarms)),
                  file=sys.stderr, flush=True)
    steps = len(delays) + len(missed)
    d = [x[0] for x in delays]
    print('%d logs of %g min (%.0f machine-hours; seed %d): %d change-free, %d with a Coulomb step\n'
          % (n, o.log_minutes, n * duration / 3600.0, o.seed, n - steps, steps))
    upper = (3.0 if not false else len(false) + 2.0 * math.sqrt(len(false)) + 2.0) / free_h * 1000.0
    print('| figure | value |')
    print('|---|---|')
    print('| change-free time watched | %.1f h |' % free_h)
    print('| false alarms | %d (%.1f per 1000 machine-hours; about %.0f at most, 95 %%) |'
          % (len(false), len(false) / free_h * 1000.0, upper))
    print('| steps alarmed (Fc, direction and sign right) | %d of %d |' % (len(delays), steps))
    print('| delay: median / 90 %% / max | %.0f / %.0f / %.0f s |' % (quantile(d, 0.5), quantile(d, 0.9), max(d) if d else float('nan')))
    print('| steps alarmed within 60 s | %d of %d |' % (sum(x <= 60.0 for x in d), steps))
    print('| other alarms after a step | %d |' % len(wrong))
    for prog, xs in sorted(by_prog.items()):
        print('| delay on %s motion: median / max | %.0f / %.0f s (%d steps) |' % (prog, quantile(xs, 0.5), max(xs), len(xs)))
    for k, prog, a in false:
        print('\nfalse alarm: log %d (%s): %s %s %+.1f %%, raised at %.0f s' % (k + 1, prog, a['parameter'], a['direction'], a['change_pct'], a['raised_t_s']))
    for delay, k, prog, ch in missed:
        print('\nmissed: log %d (%s): Fc %s %+.1f %% at %.0f s' % (k + 1, prog, ch['dir'], 100 * ch['frac'], ch['t']))
    for k, prog, a in wrong:
        print('\nafter a step, also: log %d (%s): %s %s %+.1f %%, raised at %.0f s' % (k + 1, prog, a['parameter'], a['direction'], a['change_pct'], a['raised_t_s']))


if __name__ == '__main__':
    main()
