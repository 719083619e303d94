"""Threads on a busy machine (docs/performance/threads.md): ``pfmpm bench --scenes`` of
each shipped paper scene on 1 and 2 threads, alternating, with two
``yes > /dev/null`` running, and a Markdown table of the medians.

    python tools/threads_under_load.py [--rounds N] [--null] [STEPS [SCENE ...]]

STEPS timed steps (10), N rounds (3), the named scenes only if any are given.
The table also gives the median share of the 2-thread runs' steps that the
solver's thread governor ran on one thread. With --null, the second run of
each pair is on 1 thread as well: the same protocol with nothing to find,
whose ratios show how far the machine alone moves them.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

from pfmpm import scenes

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("steps", nargs="?", default="10")
parser.add_argument("names", nargs="*", metavar="scene")
parser.add_argument("--rounds", type=int, default=3)
parser.add_argument("--null", action="store_true", help="1 thread against 1 thread")
args = parser.parse_args()
steps, names = args.steps, args.names or scenes.names()
second = 1 if args.null else 2
load = [subprocess.Popen(["yes"], stdout=subprocess.DEVNULL) for _ in range(2)]
rates: dict[tuple[str, int], list[float]] = {}
reduced: dict[str, list[float]] = {}
try:
    for round_ in range(args.rounds):
        for name in names:
            for run in (0, 1) if round_ % 2 == 0 else (1, 0):
                threads = second if run else 1
                out = subprocess.run([sys.executable, "-m", "pfmpm.cli", "bench", "--scenes",
                                      str(scenes.path(name)), "--steps", steps, "--json"],
                                     env=dict(os.environ, OMP_NUM_THREADS=str(threads)),
                                     capture_output=True, text=True, check=True)
                result = json.loads(out.stdout)[0]
                rate = result["particle_steps_per_s"] / 1e6
                rates.setdefault((name, run), []).append(rate)
                if run:
                    reduced.setdefault(name, []).append(result["reduced_thread_steps"] / result["steps"])
                print(f"round {round_ + 1}: {name}, {threads} thread(s): {rate:.3f}", file=sys.stderr)
finally:
    for p in load:
        p.kill()


def cell(values: list[float]) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


label = "1 thread again" if args.null else "2 threads"
print(f"| scene | 1 thread | {label} | ratio | steps on one thread |\n|---|---|---|---|---|")
for name in names:
    one, two = rates[(name, 0)], rates[(name, 1)]
    share = "-" if args.null else f"{statistics.median(reduced[name]):.0%}"
    print(f"| {name} | {cell(one)} | {cell(two)} | {statistics.median(two) / statistics.median(one):.2f} "
          f"| {share} |")
