"""The ``pfmpm`` command: ``pfmpm run``, ``fem``, ``compare``, ``post``,
``animate``, ``bench`` and ``polar``."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from . import __version__
from .bench import MODELS, PHYSICS
from .compare import DEFAULT_FRAMES, PROBLEMS, compare, read_study
from .run_folder import SCENE_FILE, check_fresh, check_resume, read_scene
from .scene import SceneError
from .scene.components import SHAPES, TRANSFER_SCHEMES
from .scene.units import unit_system


def _run(args: argparse.Namespace) -> int:
    from . import checkpoint, parallel
    from ._core import SimulationError
    from .scene import Scene
    from .simulation import Simulation

    if (args.scene is None) == (args.resume is None):
        print("error: pfmpm run: give a SCENE file or --resume DIR, not both", file=sys.stderr)
        return 2
    if args.resume is not None and args.set:
        print("error: --set: cannot change the scene of a resumed run", file=sys.stderr)
        return 2
    if args.resume is not None and args.overwrite:
        print("error: --overwrite: a resumed run continues its own output", file=sys.stderr)
        return 2
    resume = None
    if args.resume is not None:
        try:
            resume = checkpoint.find(args.resume)
        except checkpoint.CheckpointError as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
        scene = Scene.from_dict(resume.scene)
        # The run directory holds checkpoints/; its output continues there.
        out = Path(args.out) if args.out else resume.path.parent.parent
        every = resume.checkpoint_every if args.checkpoint_every is None else args.checkpoint_every
        keep = resume.keep if args.keep is None else args.keep
        check_resume(out, resume)
    else:
        scene = Scene.from_toml(args.scene, overrides=args.set)
        out = Path(args.out) if args.out else Path("out") / Path(args.scene).stem
        every = args.checkpoint_every or 0
        keep = 3 if args.keep is None else args.keep
        check_fresh(out, args.overwrite)
    if keep < 1:
        print(f"error: --keep {keep}: must be >= 1", file=sys.stderr)
        return 2
    comm = None
    if parallel.ranks() > 1:  # under mpirun -n N: a slab of the grid per rank
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
    root = comm is None or comm.rank == 0
    # Rank 0 says what happened; the ranks agree on a run's errors (DistributedSimulation).
    err_out = sys.stderr if root else open(os.devnull, "w")
    try:
        sim = Simulation(scene) if comm is None else parallel.DistributedSimulation(scene, comm)
    except parallel.RankError as err:
        print(f"error: {err}", file=err_out)
        return 2
    except SimulationError as err:
        print(f"error: {err}", file=err_out)
        return 1
    where = f" from step {resume.step} ({resume.path})" if resume else ""
    if not root:  # rank 0 reports
        sys.stdout = err_out
    count = len(sim.particles) if comm is None else sim.owned_count()
    ranks = f" on {comm.size} ranks" if comm is not None else ""
    print(f"{scene.name}: {count} particles, {scene.steps()} steps of dt = {scene.dt():.6g}{where}"
          f"{ranks} -> {out}")
    for line in sim.setup.lines():
        print(f"  {line}")
    for warning in sim.setup.warnings:  # with the report: stderr's first line is a failure's
        print(f"warning: {warning}")
    try:
        result = sim.run(out, progress=not args.quiet, checkpoint_every=every, keep=keep, resume=resume,
                         draw=False, overwrite=args.overwrite)
    except checkpoint.CheckpointError as err:
        print(f"error: {err}", file=err_out)
        return 2
    del sim  # the figures need none of its state: draw them without it
    result.figures.draw()
    # Each light node held at most Solver.mass_tol of mass, so at most that times the top
    # speed of momentum: summed, a bound far below round-off unless it ran for very long.
    matters = "negligible" if result.light_momentum < 1e-9 else "check which particles sit at node edges"
    light = (f"note: {result.light_nodes} grid node-steps had a mass too small to divide by and were given"
             f" zero velocity; the momentum they held is at most {result.light_momentum:.2g} of the total"
             f" mass times the top particle speed: {matters}")
    if result.status == "failed":  # the error first: a failure's first line says what failed
        print(f"error: {result.error}", file=err_out)
        print(f"output so far is in {out}; the state at the failure is in {result.checkpoint}", file=err_out)
        if result.light_nodes:
            print(light, file=err_out)
        return 1
    if result.light_nodes:
        print(light, file=err_out)
    if result.status == "interrupted":
        print(f"interrupted at step {result.steps}; output so far is in {out};"
              f" resume with: pfmpm run --resume {out}", file=err_out)
        return 128 + (result.signal or 2)
    print(f"done: {result.steps} steps in {result.wall_s:.1f} s; output in {out}")
    return 0


def _fem(args: argparse.Namespace) -> int:
    from .fem import run_command

    out = args.out or str(Path("out") / f"{Path(args.scene).stem}_fem")
    return run_command(args.scene, out, args.set, args.quiet, args.overwrite)


def _animate(args: argparse.Namespace) -> int:
    from .animate import animate

    try:
        path = animate(args.run_dir, args.output, args.field, args.fps)
    except (KeyError, ValueError) as err:
        print(f"error: {err.args[0]}", file=sys.stderr)
        return 2
    print(f"animation: {path}")
    return 0


def _count(text: str) -> int:
    """A non-negative integer command-line value."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: must be an integer") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: must be >= 0")
    return n


def _bench(args: argparse.Namespace) -> int:
    from .bench import bench, markdown_table, scenes_bench

    if args.scenes is not None:
        from . import scenes

        paths = args.scenes or [scenes.path(name) for name in scenes.names()]
        rows = scenes_bench(paths, args.steps, args.set)
        print(json.dumps(rows) if args.json else markdown_table(rows), end="" if not args.json else "\n")
        return 0
    try:
        r = bench(args.physics, args.particles, args.steps, args.repeats, args.degree, args.model,
                  args.per_cell, args.bands, args.shape, args.transfer, args.dim)
    except SceneError as err:  # the block's grid: --degree with --shape
        print(f"error: --degree, --shape: {err}", file=sys.stderr)
        return 2
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(r))
    else:
        for key, value in r.items():
            print(f"{key:>22}: {value:.4g}" if isinstance(value, float) else f"{key:>22}: {value}")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from ._core import SimulationError
    from .checkpoint import CheckpointError

    problem = PROBLEMS[args.problem]
    out = Path(args.out or f"out/compare_{args.problem}")
    if args.resume:
        given = [f"--{k}" for k in ("h", "l0", "end", "scene", "set", "frames", "model")
                 if getattr(args, k) is not None]
        if args.overwrite:
            given.append("--overwrite")
        if given:
            print(f"error: {given[0]}: cannot change the study of a resumed comparison", file=sys.stderr)
            return 2
        study = read_study(out)
        hs, l0, end, scene, sets, frames, model = (
            study[k] for k in ("h", "l0", "end", "scene", "overrides", "frames", "model"))
    else:
        try:
            hs = [float(h) for h in (args.h or ",".join(f"{h:g}" for h in problem.h)).split(",")]
        except ValueError:
            print(f"error: --h {args.h}: must be a comma-separated list of numbers", file=sys.stderr)
            return 2
        l0 = problem.l0 if args.l0 is None else args.l0
        end = problem.end if args.end is None else args.end
        scene, sets = args.scene or str(problem.path), args.set or []
        frames = DEFAULT_FRAMES if args.frames is None else args.frames
        model = args.model or "AT2"
    try:
        result = compare(out, hs, l0, end, scene_path=scene, overrides=sets, progress=not args.quiet,
                         frames=frames, resume=args.resume, model=model, overwrite=args.overwrite,
                         title=problem.title)
    except (ValueError, CheckpointError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except SimulationError as err:
        print(f"error: {err}", file=sys.stderr)
        print(f"output so far is in {out}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted; output so far is in {out}; continue with:"
              f" pfmpm compare {args.problem} --resume --out {out}", file=sys.stderr)
        return 130
    a, ref = result.agreement, result.reference
    branching = ("" if "crack_area_end" in result.rows[0] else  # a 3D crack has a front, no branches
                 f", branching {a['branch_mpm_us']:.3f} vs {a['branch_fem_us']:.3f} us")
    print(f"{model}: agreement at h = {result.h_common:g}: initiation {a['initiation_mpm_us']:.3f} (MPM)"
          f" vs {a['initiation_fem_us']:.3f} us (FEM){branching}"
          f" (each +- {a['record_interval_us']:.3f} us); elastic energy"
          f" RMS difference {100 * a['elastic_rms_rel']:.2f} % of the peak; end fracture energy"
          f" {100 * a['fracture_end_rel_diff']:+.2f} %")
    print(f"errors against the {ref['kind']} reference {ref['value']:.5g}: "
          + ", ".join(f"{r['method']} h = {r['h']:g}: {100 * r['error']:.2f} %" for r in result.rows))
    for name, path in result.files.items():
        print(f"{name}: {path}")
    return 0


def _polar(args: argparse.Namespace) -> int:
    from . import anisotropy

    try:
        gamma = anisotropy.check_gamma(anisotropy.parse_gamma(args.gamma))
    except ValueError as err:
        print(f"error: --gamma {args.gamma!r}: {err}", file=sys.stderr)
        return 2
    if not args.gc_bar > 0:
        print(f"error: --gc-bar {args.gc_bar:g}: must be > 0", file=sys.stderr)
        return 2
    table = anisotropy.polar_table(gamma, args.gc_bar, args.phi, args.samples)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    anisotropy.write_polar_csv(table, out)
    png = out.with_suffix(".png")
    anisotropy.plot_polar(table, png, f"gamma = {args.gamma}, G-bar_c = {args.gc_bar:g},"
                                      f" phi = {args.phi:g} deg")
    lo, hi = table[:, 1].argmin(), table[:, 1].argmax()
    print(f"Gc_min = {table[lo, 1]:.6g} at theta = {table[lo, 0]:g} deg (weakest crack direction)")
    print(f"Gc_max = {table[hi, 1]:.6g} at theta = {table[hi, 0]:g} deg")
    print(f"table: {out}\nplots: {png}")
    return 0


def _post(args: argparse.Namespace) -> int:
    from . import post
    from .scene import Scene

    run_dir = Path(args.run_dir)
    kept = run_dir / SCENE_FILE
    if args.scene is None and args.set:
        print(f"error: --set: only with --scene; {kept} is the run's scene, its --set values applied",
              file=sys.stderr)
        return 2
    if args.scene is not None and kept.is_file():
        print(f"error: --scene {args.scene}: {run_dir} keeps the run's own scene, {kept}", file=sys.stderr)
        return 2
    scene = read_scene(run_dir) if args.scene is None else Scene.from_toml(args.scene, overrides=args.set)
    if args.measure in ("crack-tip", "crack-directions") and not scene.cracks:
        print(f"error: {args.scene or kept}: {args.measure} needs an initial crack ([[cracks]])",
              file=sys.stderr)
        return 2
    if args.measure == "crack-tip":
        try:
            report = post.run_cracks(scene, run_dir)
        except FileNotFoundError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
    elif args.measure == "crack-directions":
        report = post.run_directions(scene, run_dir, args.history)
    elif args.measure in ("forces", "load-displacement"):
        try:
            report = (post.run_forces(scene, run_dir) if args.measure == "forces"
                      else post.run_load_displacement(scene, run_dir, args.region))
        except KeyError as error:
            print(f"error: {run_dir}: {error.args[0]}", file=sys.stderr)
            return 2
    else:
        report = post.run_fragments(scene, run_dir)
    if args.json:
        print(json.dumps(report, default=str))
    elif args.measure == "crack-tip":
        _print_tip(report, unit_system(scene.units))
    elif args.measure == "crack-directions":
        _print_directions(report)
    elif args.measure == "forces":
        u = report["units"]
        for name, peak in report["peaks"].items():
            print(f"{name.replace('_', ' ')}: largest {peak['value']:.6g} {u['force']} at t = {peak['t']:.4g} {u['time']}")
        print(f"forces: {report['csv']}\nplot: {report['png']}")
    elif args.measure == "load-displacement":
        u = report["units"]
        print(f"region {report['region']} along {report['component']}: largest load {report['peak_load']:.6g}"
              f" {u['force']} at displacement {report['displacement_at_peak']:.6g} {u['length']}")
        print(f"curve: {report['csv']}\nplot: {report['png']}")
    else:
        for row in report:
            counts = ", ".join(f"{name}: {k}" for name, k in row["fragments"].items())
            print(f"t = {row['t']:8.2f}  fragments {counts}  closest {row['closest']:.2f} spacings")
    return 0


def _print_tip(r: dict, units) -> None:
    from .post.tip import INITIATION_ADVANCE

    t, length, speed = ((f" {u}" if units.declared else " (scene units)")
                        for u in (units.time, units.length, units.speed))
    xy = lambda p: f"({p[0]:.4g}, {p[1]:.4g}){length}"  # noqa: E731
    print(f"crack initiation: t = {r['initiation']:.4g}{t} (an arm of the crack from the notch"
          f" {INITIATION_ADVANCE:g}{length} long)")
    print(f"branching: t = {r['branching']:.4g}{t} (the crack from the notch with two arms)")
    for k, crack in enumerate(r["cracks"], 1):
        start = "from the notch tip" if crack["from_notch"] else "starting"
        merged = "" if math.isnan(crack["merged"]) else f", merged into an older crack at t = {crack['merged']:.4g}{t}"
        print(f"crack {k}: {start} at {xy(crack['origin'])}, t = {crack['born']:.4g}{t}{merged}")
        for arm in crack["arms"]:
            ended = "" if math.isnan(arm["ended"]) else f", ended at t = {arm['ended']:.4g}{t}"
            print(f"  arm {arm['arm']}: from t = {arm['born']:.4g}{t}{ended}; tip {xy(arm['tip_end'])},"
                  f" {arm['length_end']:.4g}{length} from the crack's start; largest speed"
                  f" {arm['max_speed']:.4g}{speed} = {arm['max_speed'] / r['rayleigh']:.3f} v_R")
    print(f"arms: {r['csv']}\nplot: {r['png']}")


def _print_directions(r: dict) -> None:
    print(f"{r['snapshot']}: {r['particles']} particles, {r['newly_cracked']} newly cracked"
          f" (c < {r['threshold']:g})")
    print("weak directions of 1/G_c:", ", ".join(f"{w:.1f}" for w in r["weak_directions"])
          or "none (isotropic)")
    for k, tip in enumerate(r["tips"]):
        (x, y) = tip["tip"]
        print(f"tip ({x:g}, {y:g}): crack left at {tip['angle']:.1f} deg"
              f" ({tip['off_weak']:.1f} deg from the nearest weak direction)")
        for radius, arms in tip["arms"].items():
            print(f"  arms ahead at r = {radius:g}: " + (", ".join(f"{a:.1f}" for a in arms) or "none"))
        if "history" in r:
            from .post.arms import HISTORY_RINGS

            print("  t | new crack direction (deg) at " + ", ".join(f"{a}-{b}" for a, b in HISTORY_RINGS)
                  + " l0")
            for row in r["history"]:
                print(f"  {row['t']:6.1f} | " + ", ".join(f"{a:5.1f}" for a in row["rings"][k]))


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``pfmpm`` console command."""
    parser = argparse.ArgumentParser(prog="pfmpm", description="Phase-field material point method")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene file")
    run.add_argument("scene", nargs="?", help="scene TOML file (not with --resume)")
    run.add_argument("--out", help="output directory (default out/<scene name>; with --resume, the run's own);"
                                   " it keeps the scene as scene.toml")
    run.add_argument("--overwrite", action="store_true",
                     help="if the output directory holds another run, delete that run's files first"
                          " (without it, such a directory is refused)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value, e.g. time.end=10")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--checkpoint-every", type=_count, metavar="N",
                     help="write a checkpoint to OUT/checkpoints every N steps (default: none;"
                          " with --resume, as before)")
    run.add_argument("--keep", type=_count, metavar="K",
                     help="keep the newest K checkpoints (default 3; with --resume, as before)")
    run.add_argument("--resume", metavar="DIR",
                     help="continue the run in DIR (its newest checkpoint) or from a checkpoint file")
    run.set_defaults(func=_run)

    fem = sub.add_parser("fem", help="run a scene file with the phase-field FEM reference (DOLFINx);"
                                     " under mpirun -n N on N ranks")
    fem.add_argument("scene", help="scene TOML file: one rectangular body on grid lines")
    fem.add_argument("--out", help="output directory (default out/<scene name>_fem); it keeps the scene"
                                   " as scene.toml")
    fem.add_argument("--overwrite", action="store_true",
                     help="if the output directory holds another run, delete that run's files first")
    fem.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. time.end=10")
    fem.add_argument("--quiet", action="store_true", help="no progress bar")
    fem.set_defaults(func=_fem)

    bench = sub.add_parser("bench", help="time the core step on a synthetic block",
                           description="Time the core's explicit step on a square block of particles"
                                       " (3 x 3 per cell, vibrating in a smooth mode), or with --dim 3"
                                       " a cube (2 x 2 x 2 per cell), and report the median of the"
                                       " repeats: particle-steps per second, the peak memory per"
                                       " particle, and the phase-field iterations where there is one.")
    bench.add_argument("--physics", default="elastic", choices=PHYSICS,
                       help="elastic: the momentum step alone; phasefield: a crackable block with an"
                            " initial crack, the AT2 phase field solved every step; anisotropic: the"
                            " same with the fourth-order cubic surface energy; contact: the block cut"
                            " in two bodies with frictional contact (default %(default)s)")
    bench.add_argument("--particles", type=int, default=1_000_000,
                       help="about this many particles (default %(default)d)")
    bench.add_argument("--steps", type=int, default=20, help="steps per timed repeat (default %(default)d)")
    bench.add_argument("--repeats", type=int, default=3,
                       help="timed repeats, after 2 warm-up steps; the median is reported"
                            " (default %(default)d)")
    bench.add_argument("--degree", type=int, default=2, choices=[1, 2, 3],
                       help="B-spline degree of the grid (default %(default)d)")
    bench.add_argument("--shape", default="bspline", choices=SHAPES,
                       help="shape functions: B-splines, or CPDI1 (with --degree 1)")
    bench.add_argument("--model", default="linear_elastic", choices=MODELS,
                       help="material model (neo_hookean: with --physics elastic or contact)")
    bench.add_argument("--per-cell", type=int, default=None,
                       help="particles per cell and direction (default 3 in 2D, 2 in 3D)")
    bench.add_argument("--dim", type=int, default=2, choices=[2, 3],
                       help="2: a square block; 3: a cube on B-splines or CPDI, elastic, in contact or"
                            " with the damage-gradient partition (default %(default)d)")
    bench.add_argument("--transfer", default="flip", choices=TRANSFER_SCHEMES,
                       help="particle-grid transfer: FLIP (default) or APIC ([transfer] scheme)")
    bench.add_argument("--bands", type=int, default=1,
                       help="damage_gradient: fully damaged bands (planes in 3D) per direction (default 1)")
    bench.add_argument("--json", action="store_true", help="print one JSON object")
    bench.add_argument("--scenes", nargs="*", metavar="SCENE",
                       help="instead of the block, time --steps steps of each scene file (default:"
                            " the shipped paper scenes), one process each, and print a table of"
                            " particle-steps/s, CG iterations per solve and peak bytes per particle")
    bench.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="with --scenes: override a scene value in every scene")
    bench.set_defaults(func=_bench)

    comparison = sub.add_parser("compare", help="run PF-MPM and PF-FEM on a benchmark and compare them")
    defaults = "; ".join(f"{name}: {','.join(f'{h:g}' for h in p.h)}, {p.l0:g}, {p.end:g}"
                         for name, p in PROBLEMS.items())
    comparison.add_argument("problem", choices=list(PROBLEMS),
                         help="the benchmark: the Borden plate, or the 3D notched beam struck at"
                              f" mid-span; its defaults of --h, --l0 and --end: {defaults}")
    comparison.add_argument("--h", help="grid spacings, comma-separated (default: the problem's)")
    comparison.add_argument("--l0", type=float, help="phase-field length scale (default: the problem's)")
    comparison.add_argument("--end", type=float, help="end time (default: the problem's)")
    comparison.add_argument("--model", choices=["AT2", "AT1"],
                         help="phase-field model of both methods (default AT2)")
    comparison.add_argument("--out", help="output directory (default out/compare_PROBLEM)")
    comparison.add_argument("--scene", help="the scene file (default: the problem's shipped scene)")
    comparison.add_argument("--set", action="append", metavar="KEY=VALUE",
                         help="override a scene value for both methods,"
                              " e.g. bodies.plate.particles_per_cell=2")
    comparison.add_argument("--frames", type=_count,
                         help="particle (MPM) and field (FEM) frames per run, evenly spaced in time"
                              f" (default {DEFAULT_FRAMES}; 0: none)")
    comparison.add_argument("--resume", action="store_true",
                         help="continue the comparison in --out with its own settings: keep the"
                              " completed runs, resume an interrupted MPM run from its checkpoint")
    comparison.add_argument("--overwrite", action="store_true",
                         help="if --out holds another comparison or run, delete its files first"
                              " (without it, such a directory is refused)")
    comparison.add_argument("--quiet", action="store_true", help="no progress bars")
    comparison.set_defaults(func=_compare)

    polar = sub.add_parser("polar",
                           help="anisotropic surface energy G_c(theta) of a gamma tensor (K&T eq. 8)")
    polar.add_argument("--gamma", required=True, metavar="G11,G12,G13;G21,G22,G23;G31,G32,G33",
                       help="Voigt tensor of K&T eq. 6 on (c_11, c_22, c_12), material frame")
    polar.add_argument("--gc-bar", type=float, required=True, help="reference fracture energy G-bar_c")
    polar.add_argument("--phi", type=float, default=0.0,
                       help="principal material direction, degrees clockwise from x (default %(default)g)")
    polar.add_argument("--samples", type=int, default=721,
                       help="directions over 0-360 degrees (default %(default)d: every 0.5 degree)")
    polar.add_argument("--out", default="polar.csv",
                       help="CSV file theta_deg,gc,inv_gc; the plots go next to it as .png"
                            " (default %(default)s)")
    polar.set_defaults(func=_polar)

    measure = sub.add_parser("post", help="measure a finished run: crack tip, crack directions, forces,"
                                          " load-displacement, fragments")
    measure.add_argument("measure", choices=["crack-tip", "crack-directions", "forces", "load-displacement",
                                             "fragments"],
                         help="crack-tip: every crack, where and when it started, and each of its arms' tip,"
                              " length and speed (crack_path.csv; writes crack_arms.csv and .png);"
                              " crack-directions: where the new crack left each notch tip, against the"
                              " weak directions of G_c(theta); forces: the reactions of the walls and"
                              " prescribed regions and each body's net force, mean over each interval"
                              " between rows of energies.csv (forces.csv, forces.png); load-displacement:"
                              " a prescribed region's load against its displacement"
                              " (load_displacement.csv, .png); fragments: fragments per body and the"
                              " closest approach of two bodies at every particle snapshot")
    measure.add_argument("run_dir", help="the run's output directory, whose scene.toml is the scene it ran")
    measure.add_argument("--scene", help="the scene file, for a run directory without scene.toml"
                                         " (written by a pfmpm before it kept one)")
    measure.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                         help="with --scene: the --set overrides the run was given")
    measure.add_argument("--region", help="load-displacement: the prescribed region (default: the only one)")
    measure.add_argument("--history", action="store_true",
                         help="crack-directions: also the direction near each tip at every snapshot")
    measure.add_argument("--json", action="store_true", help="print one JSON object")
    measure.set_defaults(func=_post)

    anim = sub.add_parser("animate", help="an animation (GIF, or MP4 with ffmpeg) of a field over a run's"
                                          " frames, or a PNG of its last; 3D runs as particles in perspective")
    anim.add_argument("run_dir", help="the run's output directory (particles.pvd or fields.xdmf)")
    anim.add_argument("--field", default="c",
                      help="the field: c (the phase field), damage, velocity, displacement, ..."
                           " (default %(default)s)")
    anim.add_argument("--output", help="a .gif or .mp4 file, or a .png of the last frame (default"
                                       " RUN_DIR/<field>.gif)")
    anim.add_argument("--fps", type=float, default=6.0, help="frames per second (default %(default)g)")
    anim.set_defaults(func=_animate)

    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (SceneError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory: the scene is too large for this machine", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
