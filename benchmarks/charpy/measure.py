"""The measures of the modified Charpy impact (Homel & Herbold 2017, section 3.3;
``shared/benchmarks-homel-herbold.md`` section 5): the energy the system has
lost against the fracture energy, the crack band, and the momentum.

The system is the striker and the bar together, free-free, so its energy
E = kinetic + stored (``kinetic + elastic`` of ``energies.csv``) starts as the
striker's kinetic energy KE0 and can only be lost: to the damage model
(``damage_dissipation``, the work V_0 W+ dD it dissipated), to friction
(``friction_dissipation``), and to the scheme (the grid transfers' numerical
loss, and in a single velocity field the "phantom" dissipation of the two
sides of a crack dragged through each other). :func:`energy_balance` splits
the loss dE = KE0 - E_final into these; :func:`crack_band` measures the
damaged band (check C6), :func:`momentum_error` the drift of the momentum
(C7), and :func:`contact_end` when the striker has left the bar (C1).
"""

from __future__ import annotations

import numpy as np

from pfmpm.post.fragments import FULL_DAMAGE, MIN_POINTS
from pfmpm.scene import Rectangle, Scene

__all__ = ["WINDOW", "SETTLED", "fracture_energy", "energy_balance", "momentum_error",
           "contact_end", "crack_band"]

WINDOW = 0.3
"""The late window of :func:`energy_balance`: the last 30 % of the run (check C1)."""



SETTLED = 1e-9
"""A body's momentum is settled when it stays within this of its final value,
relative to its largest (no contact force acts on it any more)."""


def _bar(scene: Scene, name: str):
    """The notched rectangular bar ``name``: its body, its rectangle, and its
    notch's root x (the smallest x of its holes) and y range (of all its holes)."""
    bar = scene.body(name)
    if not isinstance(bar.shape, Rectangle) or not bar.holes:
        raise ValueError(f"body {name!r}: the Charpy measures need a rectangle with a notch (holes)")
    bounds = np.array([hole.bounds() for hole in bar.holes])
    return bar, bar.shape, (float(bounds[:, 0].min()), float(bounds[:, 1].min()), float(bounds[:, 3].max()))


def fracture_energy(scene: Scene, name: str = "target") -> float:
    """G_f A_f: the bar's fracture energy G_f times the ligament's area, from the
    face ``shape.min[0]`` to the notch root (the smallest x of its holes),
    times the thickness (the paper's expected dissipation, 354.1 mJ)."""
    bar, shape, (root, _, _) = _bar(scene, name)
    return scene.material_of(bar).damage.Gf * (root - shape.min[0]) * scene.thickness


def energy_balance(e: dict, window: float = WINDOW, after: float | None = None) -> dict:
    """The energy lost by the striker-bar system, from the columns of ``energies.csv``.

    Parameters
    ----------
    e : dict of str to ndarray
        ``t``, ``kinetic``, ``elastic``, and where the scene has them
        ``damage_dissipation`` and ``friction_dissipation``.
    window : float
        The late window, a fraction of the run at its end: E_final and the
        dissipations are means over it.
    after : float, optional
        Time from which ``overshoot`` is taken (the end of contact in the
        elastic impact, check C1); default the start of the late window.

    Returns
    -------
    dict
        ``KE0`` (E at t = 0), ``E_final`` (mean E over the window), ``dE`` =
        KE0 - E_final, ``loss`` = dE / KE0 (C1: 0.005-0.045), ``overshoot`` =
        max E / KE0 - 1 from ``after`` on (C1: below 0.01), ``damage`` and
        ``friction`` (the mean dissipations over the window), ``numerical`` =
        dE - damage - friction (what the scheme lost: phantom dissipation and
        the transfers' loss), ``drift`` (mean E over the window's second half
        minus its first half, over KE0: how flat E has become) and ``window``
        (its start and end times).
    """
    if not 0.0 < window <= 1.0:
        raise ValueError(f"window = {window}: must lie in (0, 1]")
    t = np.asarray(e["t"], dtype=float)
    energy = np.asarray(e["kinetic"], dtype=float) + np.asarray(e["elastic"], dtype=float)
    start = t[-1] - window * (t[-1] - t[0])
    late = t >= start
    half = t >= 0.5 * (start + t[-1])
    ke0 = float(energy[0])
    final = float(energy[late].mean())
    zero = np.zeros_like(t)
    damage = float(np.asarray(e.get("damage_dissipation", zero))[late].mean())
    friction = float(np.asarray(e.get("friction_dissipation", zero))[late].mean())
    dE = ke0 - final
    since = t >= (start if after is None else after)
    return {"KE0": ke0, "E_final": final, "dE": dE, "loss": dE / ke0,
            "overshoot": float(energy[since].max()) / ke0 - 1.0 if since.any() else float("nan"),
            "damage": damage, "friction": friction, "numerical": dE - damage - friction,
            "drift": float(energy[half].mean() - energy[late & ~half].mean()) / ke0,
            "window": (float(start), float(t[-1]))}


def momentum_error(e: dict) -> float:
    """Largest change of the total momentum from t = 0 over its size at t = 0
    (check C7: the free-free system keeps it)."""
    px, py = np.asarray(e["momentum_x"]), np.asarray(e["momentum_y"])
    return float(np.hypot(px - px[0], py - py[0]).max() / np.hypot(px[0], py[0]))


def contact_end(scene: Scene, run_dir, name: str = "striker") -> float | None:
    """The first particle snapshot of a run from which on the momentum of the
    body ``name`` stays within :data:`SETTLED` of its value at the end,
    relative to its largest: the internal forces of a body sum to zero at
    every node, so its momentum changes only by contact. None if it is still
    changing at the last snapshot but one."""
    from pfmpm.post.frames import read_frame, series

    index = [b.name for b in scene.bodies].index(name)
    times, momenta = [], []
    for t, path in series(run_dir):
        frame = read_frame(t, path)
        mine = frame.data["body"] == index
        # The body's particles have equal masses (one lattice, one density).
        times.append(t)
        momenta.append(frame.data["velocity"][mine, :2].sum(axis=0))
    p = np.asarray(momenta)
    off = np.hypot(*(p - p[-1]).T) > SETTLED * np.hypot(*p.T).max()
    if not off.any():
        return times[0]
    last = int(np.flatnonzero(off)[-1]) + 1
    return times[last] if last < len(times) - 1 else None


def crack_band(scene: Scene, x0: np.ndarray, damage: np.ndarray, body: np.ndarray,
               name: str = "target", threshold: float = FULL_DAMAGE) -> dict:
    """The failed particles of a notched rectangular bar, in the reference
    configuration (check C6).

    The bar's particles with D >= ``threshold`` (default
    :data:`~pfmpm.post.fragments.FULL_DAMAGE`,
    the D = 1 set) are marked on its particle
    lattice at their initial positions ``x0`` and labelled as 8-connected
    sets (``scipy.ndimage.label``); sets of fewer than
    :data:`~pfmpm.post.fragments.MIN_POINTS` particles are debris. The band
    is the largest set. The ligament runs in x from the bar's face
    ``shape.min[0]`` to the notch root, the smallest x of its holes (a notch
    cut from the face ``shape.max[0]``).

    Returns
    -------
    dict
        ``paths`` (sets of at least MIN_POINTS particles), ``failed`` (the
        failed particles), ``in_band`` (the share of them in the band),
        ``from_root`` (the band has a particle within one cell of the notch
        root's x, inside the notch's y range widened by a cell),
        ``across`` (the share of the ligament's lattice columns the band
        crosses), ``width`` (its area over the ligament's length, in cells),
        ``column_width_median`` and ``column_width_max`` (its extent in y per
        lattice column of the ligament, in cells), ``area`` (its area in the
        plane) and ``failed_area`` (all failed particles').
    """
    from scipy import ndimage

    index = [b.name for b in scene.bodies].index(name)
    bar, shape, (root, low, high) = _bar(scene, name)
    h = scene.grid.h
    s = bar.spacing(h)
    mine = np.asarray(body) == index
    lattice = np.rint((np.asarray(x0)[mine] - np.asarray(shape.min)) / s - 0.5).astype(int)
    failed = np.asarray(damage)[mine] >= threshold
    image = np.zeros(lattice.max(axis=0) + 1, dtype=bool)
    image[tuple(lattice[failed].T)] = True
    labels, count = ndimage.label(image, structure=np.ones((3, 3), dtype=int))
    sizes = np.bincount(labels.ravel())[1:]
    report = {"paths": int(np.count_nonzero(sizes >= MIN_POINTS)), "failed": int(failed.sum()),
              "in_band": 0.0, "from_root": False, "across": 0.0, "width": 0.0,
              "column_width_median": 0.0, "column_width_max": 0.0, "area": 0.0,
              "failed_area": float(failed.sum()) * s * s}
    if count == 0:
        return report
    band = labels == 1 + int(np.argmax(sizes))
    front, lo, hi = shape.min[0], low - h, high + h
    centres = np.asarray(shape.min) + (np.argwhere(band) + 0.5) * s
    columns = int(round((root - front) / s))
    per_column = band[:columns].sum(axis=1) * s / h
    crossed = per_column > 0
    report.update(
        in_band=float(band.sum()) / failed.sum(),
        from_root=bool(np.any((centres[:, 0] >= root - h) & (centres[:, 1] >= lo)
                              & (centres[:, 1] <= hi))),
        across=float(crossed.mean()),
        width=float(band[:columns].sum()) * s * s / (root - front) / h,
        column_width_median=float(np.median(per_column[crossed])) if crossed.any() else 0.0,
        column_width_max=float(per_column.max()),
        area=float(band.sum()) * s * s)
    return report
