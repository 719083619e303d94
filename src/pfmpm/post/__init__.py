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
``disk_beam``
    The disk-beam crack's rise through the beam, its fracture energy counted
    as the paper counts it (:func:`~pfmpm.post.disk_beam.running_crack`) and
    the Hertzian cone index (:func:`~pfmpm.post.disk_beam.cone_index`).
``frames``
    The particle snapshots of a finished run.
``efficiency``
    The cost of damage-gradient partitioning against particle count, per
    stage, and the checks E1-E5 of Homel & Herbold 2017, section 3.5
    (:func:`~pfmpm.post.efficiency.study`, :func:`~pfmpm.post.efficiency.checks`;
    the driver is ``tools/efficiency.py``).
``self_contact``
    Damage-gradient self-contact against the multi-field and single-field
    runs (Homel & Herbold 2017, section 3.1): the billet's checks B1-B4 and
    the wedge's W1-W4 (:func:`~pfmpm.post.self_contact.run_variants`);
    :func:`~pfmpm.post.self_contact.body_fields`, the single-field run of
    the impact problems.
``kalthoff_winkler``
    The crack that leaves a notch tip in a damage model's run (Homel &
    Herbold 2017, section 3.2): its angle, tip speed and arms, checks K1-K4
    (:func:`~pfmpm.post.kalthoff_winkler.run_crack`); failure at full
    damage, not at ``output.crack_threshold``.
``charpy``
    The modified Charpy impact (Homel & Herbold 2017, section 3.3): the energy
    the striker-bar system loses, split into damage, friction and the
    scheme's loss (:func:`~pfmpm.post.charpy.energy_balance`), the crack band
    (:func:`~pfmpm.post.charpy.crack_band`) and the momentum.
``brazilian``
    The dynamic Brazilian disk (Homel & Herbold 2017, section 3.4): the
    disk's fragment-size distribution and mean speed, its fully damaged
    fraction, and how far particles pass a wall or into a platen (checks
    Z1-Z6, :func:`~pfmpm.post.brazilian.disk_fragments`).

``pfmpm post crack-tip|crack-directions|forces|load-displacement|fragments RUN_DIR`` prints the
measures that read a finished run's output directory, with the scene the run
kept there (:func:`pfmpm.run_folder.read_scene`).
"""

from .arms import crack_arms, crack_directions, propagation_angle, run_directions
from .cracks import Cracks, run_cracks, track_cracks
from .disk_beam import cone_index, crack_rise, running_crack
from .forces import load_displacement, mean_forces, run_forces, run_load_displacement
from .fragments import closest_approach, count_fragments, fragments, run_fragments
from .tip import branch_time, initiation_time

__all__ = ["Cracks", "track_cracks", "run_cracks", "initiation_time", "branch_time",
           "propagation_angle", "crack_arms", "crack_directions", "run_directions", "count_fragments", "fragments",
           "closest_approach", "run_fragments", "mean_forces", "run_forces",
           "load_displacement", "run_load_displacement", "crack_rise", "running_crack", "cone_index"]
