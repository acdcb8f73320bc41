#!/usr/bin/env python3
"""Issue 28's speed figures as a user meets them: the median wall time of
each command run from the shell, process start and file reading included,
against identify's on the same run (docs/benchmarks.md, "the replay steps
its plant as finely as the plant needs").

The model is the one `feedid identify` writes for DATA_EMPS; the commands
run on DATA_EMPS_PULSES with the EMPS controller file. The commands are
run in turn, round after round, so that a slow spell of the machine falls
on all of them alike.

    python3 host_sim/bench/cli_medians.py [--feedid build/bin/feedid] [--emps ../shared/data/emps] [--runs 21]
        [--baseline OTHER_FEEDID]

Prints a Markdown table: median and fastest time (ms) and the median's
ratio to identify's. With --baseline, each command runs with both builds
in turn (alternating which goes first), so that the machine's slow spells
fall on both alike, and a second table gives the baseline's figures.
"""
import argparse, os, statistics, subprocess, sys, tempfile, time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--feedid", default="build/bin/feedid")
    ap.add_argument("--emps", default="../shared/data/emps")
    ap.add_argument("--controller", default="docs/examples/emps_controller.json")
    ap.add_argument("--runs", type=int, default=21)
    ap.add_argument("--baseline", help="another feedid build, run alternately with --feedid")
    a = ap.parse_args()
    if a.runs < 1:
        ap.error("--runs must be >= 1")
    cols = ["--time", "t_s", "--position", "qm_m", "--force", "force_N"]
    with tempfile.TemporaryDirectory() as tmp:
        model = os.path.join(tmp, "emps_id.json")
        subprocess.run([a.feedid, "identify", "--in", os.path.join(a.emps, "DATA_EMPS.csv"), *cols, "--json", model],
                       check=True, stdout=subprocess.DEVNULL)
        run = ["--in", os.path.join(a.emps, "DATA_EMPS_PULSES.csv"), *cols]
        commands = {
            "identify": ["identify", *run],
            "diagnose": ["diagnose", *run],
            "diagnose --model": ["diagnose", "--model", model, *run],
            "diagnose --model --controller": ["diagnose", "--model", model, "--controller", a.controller, *run],
            "replay": ["replay", "--model", model, "--controller", a.controller, *run],
        }
        builds = [a.feedid] + ([a.baseline] if a.baseline else [])
        times = {(b, name): [] for b in builds for name in commands}
        for r in range(a.runs):
            print(f"round {r + 1} of {a.runs}", file=sys.stderr)
            for name, args in commands.items():
                for b in (builds if r % 2 == 0 else builds[::-1]):
                    t0 = time.perf_counter()
                    subprocess.run([b, *args], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    times[(b, name)].append(time.perf_counter() - t0)
    for b in builds:
        if a.baseline:
            print(f"\n{b}:\n")
        base = statistics.median(times[(b, "identify")])
        print("| command (EMPS PULSES) | median (ms) | fastest (ms) | against identify |")
        print("|---|---|---|---|")
        for name in commands:
            t = times[(b, name)]
            m = statistics.median(t)
            print(f"| `{name}` | {1e3 * m:.1f} | {1e3 * min(t):.1f} | {m / base:.2f}x |")


if __name__ == "__main__":
    main()
