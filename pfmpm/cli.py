"""The ``pfmpm`` command: ``pfmpm run`` and ``pfmpm bench``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .bench import PHYSICS


def _run(args: argparse.Namespace) -> int:
    from .scene import Scene
    from .simulation import Simulation

    scene = Scene.from_toml(args.scene, overrides=args.set)
    out = Path(args.out) if args.out else Path("out") / Path(args.scene).stem
    sim = Simulation(scene)
    print(f"{scene.name}: {len(sim.particles)} particles, {scene.steps()} steps of dt = {scene.dt():.6g} -> {out}")
    result = sim.run(out, progress=not args.quiet)
    if result.status == "failed":
        print(f"error: {result.error}", file=sys.stderr)
        print(f"output so far is in {out}", file=sys.stderr)
        return 1
    if result.status == "interrupted":
        print(f"interrupted at step {result.steps}; output so far is in {out}", file=sys.stderr)
        return 130
    print(f"done: {result.steps} steps in {result.wall_s:.1f} s; output in {out}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from .bench import bench

    r = bench(args.physics, args.particles, args.steps, args.repeats, args.degree)
    if args.json:
        print(json.dumps(r))
    else:
        for key, value in r.items():
            print(f"{key:>22}: {value:.4g}" if isinstance(value, float) else f"{key:>22}: {value}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``pfmpm`` console command."""
    parser = argparse.ArgumentParser(prog="pfmpm", description="Phase-field material point method")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene file")
    run.add_argument("scene", help="scene TOML file")
    run.add_argument("--out", help="output directory (default out/<scene name>)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value, e.g. time.end=10")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)

    bench = sub.add_parser("bench", help="time the core step on a synthetic block")
    bench.add_argument("--physics", default="elastic", choices=PHYSICS)
    bench.add_argument("--particles", type=int, default=1_000_000)
    bench.add_argument("--steps", type=int, default=20)
    bench.add_argument("--repeats", type=int, default=3)
    bench.add_argument("--degree", type=int, default=2, choices=[1, 2, 3])
    bench.add_argument("--json", action="store_true", help="print one JSON object")
    bench.set_defaults(func=_bench)

    args = parser.parse_args(argv)
    from .scene import SceneError

    try:
        return args.func(args)
    except (SceneError, FileNotFoundError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
