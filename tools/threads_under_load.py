"""Threads on a busy machine (docs/performance.md): ``pfmpm bench --scenes`` of
each shipped paper scene on 1 and 2 threads, alternating, 3 rounds, with two
``yes > /dev/null`` running, and a Markdown table of the medians.

    python tools/threads_under_load.py [STEPS [SCENE ...]]

with the named scenes only if any are given.
"""

import json
import os
import statistics
import subprocess
import sys

from pfmpm import scenes

steps = sys.argv[1] if len(sys.argv) > 1 else "10"
names = sys.argv[2:] or scenes.names()
load = [subprocess.Popen(["yes"], stdout=subprocess.DEVNULL) for _ in range(2)]
rates: dict[tuple[str, int], list[float]] = {}
try:
    for round_ in range(3):
        for name in names:
            for threads in (1, 2) if round_ % 2 == 0 else (2, 1):
                out = subprocess.run([sys.executable, "-m", "pfmpm.cli", "bench", "--scenes",
                                      str(scenes.path(name)), "--steps", steps, "--json"],
                                     env=dict(os.environ, OMP_NUM_THREADS=str(threads)),
                                     capture_output=True, text=True, check=True)
                rate = json.loads(out.stdout)[0]["particle_steps_per_s"] / 1e6
                rates.setdefault((name, threads), []).append(rate)
                print(f"round {round_ + 1}: {name}, {threads} thread(s): {rate:.3f}", file=sys.stderr)
finally:
    for p in load:
        p.kill()


def cell(values: list[float]) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


print("| scene | 1 thread | 2 threads | 2 / 1 |\n|---|---|---|---|")
for name in names:
    one, two = rates[(name, 1)], rates[(name, 2)]
    print(f"| {name} | {cell(one)} | {cell(two)} | {statistics.median(two) / statistics.median(one):.2f} |")
