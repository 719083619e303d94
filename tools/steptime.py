"""Wall time per step of a scene after 5 warm-up steps (docs/performance/index.md).

    python tools/steptime.py SCENE STEPS [KEY=VALUE ...] [--stages]
    python tools/steptime.py --resume DIR STEPS [--stages]

KEY=VALUE are scene overrides, as ``pfmpm run --set`` takes them. Prints the
milliseconds per step; with ``--stages`` also the wall nanoseconds per
particle-step of each stage of the step (the solver's stage timers, as
``summary.json`` reports them) and the phase field's CG iterations per solve.
``--resume DIR`` times STEPS steps from the newest checkpoint in DIR (a run
with ``--checkpoint-every``), without warm-up: a state deep into a run, such
as the paper-resolution Borden plate after its crack has grown.
"""

import argparse
import time

from pfmpm import Scene, Simulation, checkpoint

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("scene", nargs="?", help="scene TOML file (not with --resume)")
parser.add_argument("steps", type=int)
parser.add_argument("overrides", nargs="*", metavar="KEY=VALUE")
parser.add_argument("--resume", metavar="DIR", help="start from the newest checkpoint in DIR")
parser.add_argument("--stages", action="store_true", help="also the stages' ns per particle-step")
args = parser.parse_args()
if (args.scene is None) == (args.resume is None) or (args.resume and args.overrides):
    parser.error("give a SCENE with its overrides, or --resume DIR")

if args.resume:
    ckpt = checkpoint.find(args.resume)
    sim = Simulation(Scene.from_dict(ckpt.scene))
    checkpoint.restore(sim, ckpt)
else:
    sim = Simulation(Scene.from_toml(args.scene, args.overrides + ["output.particles=false"]))
    sim.advance(5)
seconds = dict(sim.solver.stage_seconds())
solves = sim.solver.phase_field_stats() if sim.cracks else None
start = time.perf_counter()
sim.advance(args.steps)
wall = time.perf_counter() - start
print(f"{1000 * wall / args.steps:.1f}")
if args.stages:
    scale = 1e9 / (len(sim.particles) * args.steps)
    stages = ", ".join(f"{name} {scale * (after - seconds[name]):.1f}"
                       for name, after in sim.solver.stage_seconds().items())
    print(f"ns per particle-step ({len(sim.particles)} particles): "
          f"all {scale * wall:.1f}; {stages}")
    if solves:
        now = sim.solver.phase_field_stats()
        solved = max(now["solves"] - solves["solves"], 1)
        per_solve = (now["iterations"] - solves["iterations"]) / solved
        print(f"CG iterations per solve: {per_solve:.2f}")
