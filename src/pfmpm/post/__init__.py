"""Measures of runs: what the papers report, computed from a run's state or output.

Each measure of a phase field reads cracks with the scene's
``output.crack_threshold``; those of a damage model read failure at full damage.

``tip``
    Crack initiation and branching from the crack-tip columns of
    ``energies.csv``, which :class:`~pfmpm.observe.CrackTip` records while a
    run goes.
``cracks``
    Every crack of a run, where and when it started, and each of its arms'
    tip, length and speed, for cracks of any direction and away from the
    notch (:func:`~pfmpm.post.cracks.run_cracks`).
``arms``
    The direction in which a crack leaves a notch tip and the arms crossing
    circles about it, against the weak directions of ``G_c(theta)``
    (:func:`~pfmpm.post.arms.crack_directions`).
``forces``
    The reactions of the walls and of the prescribed regions and each body's
    net force over a run, from the impulses and momenta of its
    ``energies.csv`` (:func:`~pfmpm.post.forces.mean_forces`); a region's
    load against its displacement
    (:func:`~pfmpm.post.forces.load_displacement`).
``fragments``
    Fragments per body and the closest approach of different bodies
    (:func:`~pfmpm.post.fragments.fragments`); fragment sizes, their
    cumulative mass-fraction distribution and its median
    (:func:`~pfmpm.post.fragments.fragment_sizes`).
``frames``
    The particle snapshots of a finished run.

Each reads a finished run's folder or a state of any scene. What only one
paper problem asks (its geometry, its checks, runs of its own) lives in the
problem's folder: ``benchmarks/<name>/measure.py`` (Kalthoff-Winkler, the
Charpy, the Brazilian disk, the disk and beam, the efficiency study) and
``benchmarks/common/self_contact.py`` (the self-contact variants of the
billet and the wedge, and the single-field run of the impact problems);
benchmarks/README.md lists them.

``pfmpm post crack-tip|crack-directions|forces|load-displacement|fragments RUN_DIR`` prints the
measures that read a finished run's output directory, with the scene the run
kept there (:func:`pfmpm.run_folder.read_scene`).
"""

from .arms import crack_arms, crack_directions, propagation_angle, run_directions
from .cracks import Cracks, run_cracks, track_cracks
from .forces import load_displacement, mean_forces, run_forces, run_load_displacement
from .fragments import closest_approach, count_fragments, fragments, run_fragments
from .tip import branch_time, initiation_time

__all__ = ["Cracks", "track_cracks", "run_cracks", "initiation_time", "branch_time",
           "propagation_angle", "crack_arms", "crack_directions", "run_directions", "count_fragments", "fragments",
           "closest_approach", "run_fragments", "mean_forces", "run_forces",
           "load_displacement", "run_load_displacement"]
