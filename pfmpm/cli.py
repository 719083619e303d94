"""The ``pfmpm`` command: ``pfmpm run``, ``pfmpm bench`` and ``pfmpm compare``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .bench import PHYSICS
from .compare import BORDEN_SCENE, DEFAULT_END, DEFAULT_H, DEFAULT_L0


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


def _compare(args: argparse.Namespace) -> int:
    from ._core import SimulationError
    from .compare import compare_borden

    try:
        hs = [float(h) for h in args.h.split(",")]
    except ValueError:
        print(f"error: --h {args.h}: must be a comma-separated list of numbers", file=sys.stderr)
        return 2
    out = Path(args.out)
    try:
        result = compare_borden(out, hs, args.l0, args.end, scene_path=args.scene, overrides=args.set,
                                progress=not args.quiet)
    except SimulationError as err:
        print(f"error: {err}", file=sys.stderr)
        print(f"output so far is in {out}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted; output so far is in {out}", file=sys.stderr)
        return 130
    a = result.agreement
    print(f"agreement at h = {result.h_common:g}: initiation {a['initiation_mpm_us']:.3f} (MPM)"
          f" vs {a['initiation_fem_us']:.3f} us (FEM); elastic energy RMS difference"
          f" {100 * a['elastic_rms_rel']:.2f} % of the peak; end fracture energy"
          f" {100 * a['fracture_end_rel_diff']:+.2f} %")
    for name, path in result.files.items():
        print(f"{name}: {path}")
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

    compare = sub.add_parser("compare", help="run PF-MPM and PF-FEM on a benchmark and compare them")
    compare.add_argument("problem", choices=["borden"], help="the benchmark (the Borden plate)")
    compare.add_argument("--h", default=",".join(f"{h:g}" for h in DEFAULT_H),
                         help="grid spacings, comma-separated (default %(default)s)")
    compare.add_argument("--l0", type=float, default=DEFAULT_L0,
                         help="phase-field length scale (default %(default)g)")
    compare.add_argument("--end", type=float, default=DEFAULT_END, help="end time (default %(default)g)")
    compare.add_argument("--out", default="out/compare_borden", help="output directory (default %(default)s)")
    compare.add_argument("--scene", default=str(BORDEN_SCENE), help="the scene file (default %(default)s)")
    compare.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                         help="override a scene value for both methods,"
                              " e.g. bodies.plate.particles_per_cell=2")
    compare.add_argument("--quiet", action="store_true", help="no progress bars")
    compare.set_defaults(func=_compare)

    args = parser.parse_args(argv)
    from .scene import SceneError

    try:
        return args.func(args)
    except (SceneError, FileNotFoundError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
