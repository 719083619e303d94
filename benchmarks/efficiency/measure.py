"""The cost of damage-gradient partitioning (Homel & Herbold 2017, section 3.5,
Fig. 19): wall time per step against particle count, with the partition
(``dfg``) and without it (``sf``: every body its own velocity field,
:func:`~benchmarks.common.self_contact.body_fields`), on one
and more threads, per stage of the step; the checks E1-E5 of
``shared/benchmarks-homel-herbold.md`` section 7 from the table of timings.

A partition costs what the damage makes it do, and the paper's disk has no
fully damaged particle for its first few microseconds, when damage-gradient
fields run as one field (docs/contact.md, "Exact shortcut"). So each timed
run may start from a painted state: the damage a damage-gradient run at the
coarsest spacing reached at ``paint_time``, given to every particle from
the reference particle of its body nearest it at t = 0
(:func:`reference_damage`, :func:`paint`). The same state for both
partitions at a size, and the same crack pattern at every size.

:func:`study` times the runs (every size, partition and thread count in
turn, per round) into rows of :data:`COLUMNS`; :func:`checks` computes E1-E5
from them and :func:`figure` draws Fig. 19. ``benchmarks/efficiency/study.py`` is the
driver.
"""

from __future__ import annotations

import hashlib
import os
import statistics
import time
from pathlib import Path

import numpy as np

from pfmpm.scene import Scene

__all__ = ["METHODS", "STAGES", "DFG_BLOCKS", "COLUMNS", "scene_at", "reference_damage", "paint",
           "time_run", "time_runs", "study", "medians", "checks", "figure"]

METHODS = ("sf", "dfg")
"""Every body its own field (0 in the table's ``dfg`` column) and damage-gradient fields (1)."""
STAGES = ("sort", "phase_field", "fields", "p2g", "grid", "g2p")
"""The stages of the step (``Solver.stage_seconds``)."""
DFG_BLOCKS = ("damage", "neighbours", "gradient", "partition")
"""The damage-gradient partition's blocks, inside the ``fields`` stage
(``Solver.damage_partition()["seconds"]``): particle damage with the open
nodes (where the fields may separate), neighbour lists (staleness checks and
builds), the kernel field's gradient (the particle DFG of the paper) and
Algorithms 1-2 with the slots."""
COLUMNS = ("round", "k", "h", "particles", "dfg", "threads", "steps", "warmup", "seconds",
           "cpu_seconds", *STAGES, *DFG_BLOCKS, "neighbour_builds", "evaluated", "digest", "load")
"""Per timed run: round, refinement k (spacing h = h0 / k), particles, partition
(1: damage gradient), threads, timed and warm-up steps, wall and process CPU
seconds per timed step, seconds per step in each stage and block, neighbour
builds in the timed steps, kernel fields evaluated per step (the particles
near full damage whose neighbours' damage differs), a digest of the positions
and velocities after the run (the first 52 bits of their SHA-256) and the
1-minute load average at its start."""

E2_RANGE = (3.2e4, 1.5e5)
"""Particle counts of check E2 (the paper's middle regime)."""


def scene_at(scene: Scene, h: float, method: str) -> Scene:
    """``scene`` at grid spacing ``h`` with partition ``method`` (:data:`METHODS`)."""
    from benchmarks.common.self_contact import body_fields

    if method not in METHODS:
        raise ValueError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    d = scene.to_dict()
    d["grid"] = dict(d["grid"], h=h)
    d.setdefault("output", {})["particles"] = False
    at = Scene.from_dict(d)
    return at if method == "dfg" else body_fields(at)


def reference_damage(scene: Scene, h: float, paint_time: float) -> dict:
    """The damage of a damage-gradient run of ``scene`` at spacing ``h`` at
    time ``paint_time``: ``x0`` (initial positions), ``body`` and ``damage``."""
    from pfmpm.simulation import Simulation

    sim = Simulation(scene_at(scene, h, "dfg"))
    x0, body = sim.particles.x.copy(), sim.particles.body.copy()
    sim.advance(int(round(paint_time / sim.dt)))
    return {"x0": x0, "body": body, "damage": sim.particles.damage.copy()}


def paint(sim, reference: dict) -> None:
    """Give each particle of ``sim`` (at t = 0) the damage of the reference
    particle of its body nearest it (:func:`reference_damage`)."""
    from scipy.spatial import cKDTree

    p = sim.particles
    damage = np.zeros(len(p))
    for b in np.unique(p.body):
        mine, theirs = np.flatnonzero(p.body == b), np.flatnonzero(reference["body"] == b)
        nearest = cKDTree(reference["x0"][theirs]).query(p.x[mine])[1]
        damage[mine] = reference["damage"][theirs[nearest]]
    p.damage[:] = damage


def time_run(scene: Scene, h: float, method: str, threads: int, steps: int | None, warmup: int,
             reference: dict | None = None, until: float | None = None) -> dict:
    """Time ``steps`` steps of ``scene`` at spacing ``h`` with partition
    ``method`` on ``threads`` threads after ``warmup`` steps, from the painted
    state of ``reference`` (or from t = 0 as the scene is); with ``until``
    instead of ``steps``, the steps to that time (the whole run, as the paper
    times it). A row of :data:`COLUMNS` without ``round``, ``k`` and ``load``;
    the thread count is set back as it was."""
    return time_runs(scene, h, (method,), threads, steps, warmup, reference, until)[0]


def time_runs(scene: Scene, h: float, methods, threads: int, steps: int | None, warmup: int,
              reference: dict | None = None, until: float | None = None,
              chunk: int | None = None) -> list[dict]:
    """:func:`time_run` for each partition of ``methods``, one row each. With
    ``chunk``, the runs advance ``chunk`` steps at a time in turn, in one
    process, so that a slow drift of a shared machine's speed falls on all
    of them alike; without, each run is timed whole, one after the other."""
    from pfmpm import _core

    if chunk is not None and chunk < 1:
        raise ValueError(f"chunk = {chunk}: must be at least 1 step")
    before = _core.num_threads()
    _core.set_num_threads(threads)
    try:
        return _time_runs(scene, h, methods, threads, steps, warmup, reference, until, chunk)
    finally:
        _core.set_num_threads(before)


def _time_runs(scene, h, methods, threads, steps, warmup, reference, until, chunk) -> list[dict]:
    """:func:`time_runs` on the threads set."""
    from pfmpm.simulation import Simulation

    def blocks(sim):
        part = sim.solver.damage_partition()
        seconds = dict(part["seconds"]) if part else dict.fromkeys(DFG_BLOCKS, 0.0)
        return {**sim.solver.stage_seconds(), **seconds,
                "neighbour_builds": part["neighbour_builds"] if part else 0,
                "evaluated": part["kernel_evaluations"] if part else 0}

    runs = []
    for method in methods:
        sim = Simulation(scene_at(scene, h, method))
        sim.solver.adaptive_threads = False  # the count asked for, every step: a thread-count study
        if reference is not None:
            paint(sim, reference)
        sim.advance(warmup)
        n = int(round(until / sim.dt)) - warmup if until is not None else steps
        runs.append({"sim": sim, "method": method, "steps": n, "done": 0, "wall": 0.0, "cpu": 0.0,
                     "before": blocks(sim)})
    while any(r["done"] < r["steps"] for r in runs):
        for r in runs:
            n = min(chunk or r["steps"], r["steps"] - r["done"])
            if n <= 0:
                continue
            wall, cpu = time.perf_counter(), time.process_time()
            r["sim"].advance(n)
            r["wall"] += time.perf_counter() - wall
            r["cpu"] += time.process_time() - cpu
            r["done"] += n
    rows = []
    for r in runs:
        sim, n, before, after = r["sim"], r["steps"], r["before"], blocks(r["sim"])
        state = np.concatenate([sim.particles.x.ravel(), sim.particles.v.ravel()])
        row = {"h": h, "particles": len(sim.particles), "dfg": METHODS.index(r["method"]),
               "threads": threads, "steps": n, "warmup": warmup, "seconds": r["wall"] / n,
               "cpu_seconds": r["cpu"] / n,
               "digest": int(hashlib.sha256(state.tobytes()).hexdigest()[:13], 16)}
        for key in (*STAGES, *DFG_BLOCKS):
            row[key] = (after[key] - before[key]) / n
        row["neighbour_builds"] = after["neighbour_builds"] - before["neighbour_builds"]
        row["evaluated"] = (after["evaluated"] - before["evaluated"]) / n
        rows.append(row)
    return rows


def study(scene: Scene, ks, h0: float, steps: int = 200, warmup: int = 50, rounds: int = 3,
          threads=(1, 2), paint_time: float | None = 10.0, csv_path: Path | None = None,
          progress=None, until: float | None = None, chunk: int | None = None) -> list[dict]:
    """Time every refinement k of ``ks`` (spacing ``h0 / k``), both partitions
    and every thread count of ``threads``, ``rounds`` times, the
    configurations alternating within a round (:func:`time_run`). With
    ``paint_time``, every run starts from the damage a damage-gradient run at
    the coarsest spacing reached then (:func:`reference_damage`); with
    ``until``, each run is timed from the warm-up to that time instead of for
    ``steps`` steps; with ``chunk``, the two partitions' runs advance
    ``chunk`` steps at a time in turn (:func:`time_runs`). Rows are appended
    to ``csv_path`` as they come (if given); ``progress(row)`` is called
    after each.
    """
    from pfmpm.output import CsvLog

    reference = None
    if paint_time is not None:
        reference = reference_damage(scene, h0 / min(ks), paint_time)
    log = CsvLog(Path(csv_path), list(COLUMNS)) if csv_path else None
    rows = []
    try:
        for r in range(rounds):
            for k in ks:
                for n in threads:
                    load = os.getloadavg()[0]
                    for timed in time_runs(scene, h0 / k, METHODS, n, steps, warmup, reference,
                                           until, chunk):
                        row = {"round": r, "k": float(k), "load": load, **timed}
                        rows.append(row)
                        if log:
                            log.write(row)
                        if progress:
                            progress(row)
    finally:
        if log:
            log.close()
    return rows


def _as_rows(table) -> list[dict]:
    """Rows from a list of dicts or from the columns of ``read_csv``."""
    if isinstance(table, dict):
        n = len(next(iter(table.values())))
        return [{k: v[i] for k, v in table.items()} for i in range(n)]
    return list(table)


def medians(table) -> dict[tuple[int, int, int], dict[str, float]]:
    """Per (particles, dfg, threads): the median over the rounds of each timed
    column of :data:`COLUMNS`."""
    groups: dict[tuple[int, int, int], list[dict]] = {}
    for row in _as_rows(table):
        groups.setdefault((int(row["particles"]), int(row["dfg"]), int(row["threads"])), []).append(row)
    keys = ("seconds", "cpu_seconds", *STAGES, *DFG_BLOCKS, "neighbour_builds", "evaluated", "load")
    return {g: {k: statistics.median(float(r[k]) for r in rows) for k in keys}
            for g, rows in sorted(groups.items())}


def _slope(n: list[float], t: list[float]) -> float | None:
    """Least-squares slope of log t against log n (None with fewer than 2 sizes)."""
    if len(n) < 2:
        return None
    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def checks(table, time: str = "seconds") -> dict:
    """Checks E1-E5 of ``shared/benchmarks-homel-herbold.md`` section 7 from
    the timing table (rows of :data:`COLUMNS`, or ``read_csv`` columns),
    on medians over the rounds (:func:`medians`), with ``time`` the time per
    step of E2 and of the slopes: ``"seconds"`` (wall) or ``"cpu_seconds"``
    (the process's CPU time, which other processes on a busy machine inflate
    less; on one thread only). The shares of E1 and E4 are of wall times
    within a run.

    - E1: the neighbour lists (checks and builds) at most 1 % of the step, at
      every size, with damage-gradient fields (every thread count);
    - E2: DFG over SF time per step at most 1.6 on one thread for
      3.2e4 < n_p < 1.5e5;
    - E3: the log-log slope of the particle DFG block (``gradient``) against
      n_p in [0.9, 1.15], on one thread; with the slope of the kernel fields
      evaluated against n_p (``evaluated_slope``: pfmpm evaluates them near
      full damage only) and of the block against them (``per_evaluation_slope``:
      1 when each evaluation costs the same at every size);
    - E4: the DFG blocks (:data:`DFG_BLOCKS`) at most 40 % of the step at the
      largest size, on one thread;
    - E5: every run of a size and partition ends with the same digest of its
      positions and velocities, whatever its thread count (bitwise).

    Each entry has ``value``, its ``limit`` and ``passed`` (None where the
    table cannot tell: no size in E2's range, one size for E3, one thread
    count for E5), with per-size values where there are several; ``slopes``
    gives the log-log slope of the time per step of each (partition, threads),
    Fig. 19's fitted lines.
    """
    rows = _as_rows(table)
    m = medians(rows)
    sizes = sorted({n for n, _, _ in m})
    out: dict = {}

    share = {}
    for (n, d, t), v in m.items():
        if d == 1:
            share[n] = max(share.get(n, 0.0), v["neighbours"] / v["seconds"])
    worst = max(share.values()) if share else None
    out["E1"] = {"value": worst, "limit": 0.01, "passed": None if worst is None else worst <= 0.01,
                 "per_size": share}

    if time not in ("seconds", "cpu_seconds"):
        raise ValueError(f"time = {time!r}: must be 'seconds' or 'cpu_seconds'")
    ratio = {n: m[(n, 1, 1)][time] / m[(n, 0, 1)][time]
             for n in sizes if (n, 1, 1) in m and (n, 0, 1) in m}
    inside = {n: r for n, r in ratio.items() if E2_RANGE[0] < n < E2_RANGE[1]}
    worst = max(inside.values()) if inside else None
    out["E2"] = {"value": worst, "limit": 1.6, "passed": None if worst is None else worst <= 1.6,
                 "per_size": ratio}

    dfg1 = [n for n in sizes if (n, 1, 1) in m]
    slope = _slope(dfg1, [m[(n, 1, 1)]["gradient"] for n in dfg1])
    evaluated = [m[(n, 1, 1)]["evaluated"] for n in dfg1]
    out["E3"] = {"value": slope, "limit": [0.9, 1.15],
                 "passed": None if slope is None else 0.9 <= slope <= 1.15,
                 "evaluated_slope": _slope(dfg1, evaluated) if all(evaluated) else None,
                 "per_evaluation_slope": (_slope(evaluated, [m[(n, 1, 1)]["gradient"] for n in dfg1])
                                          if all(evaluated) else None)}

    share = None
    if dfg1:
        v = m[(dfg1[-1], 1, 1)]
        share = sum(v[b] for b in DFG_BLOCKS) / v["seconds"]
    out["E4"] = {"value": share, "limit": 0.4, "passed": None if share is None else share <= 0.4,
                 "particles": dfg1[-1] if dfg1 else None}

    digests: dict[tuple, set] = {}
    threads: dict[tuple, set] = {}
    for row in rows:
        key = (int(row["particles"]), int(row["dfg"]), int(row["steps"]), int(row["warmup"]))
        digests.setdefault(key, set()).add(int(row["digest"]))
        threads.setdefault(key, set()).add(int(row["threads"]))
    compared = [key for key in digests if len(threads[key]) > 1]
    differ = [key for key in compared if len(digests[key]) > 1]
    out["E5"] = {"value": len(differ), "limit": 0, "passed": (not differ) if compared else None,
                 "compared": len(compared)}

    out["slopes"] = {}
    for d in (0, 1):
        for t in sorted({t for _, dd, t in m if dd == d}):
            ns = [n for n in sizes if (n, d, t) in m]
            out["slopes"][f"{METHODS[d]}_{t}"] = _slope(ns, [m[(n, d, t)][time] for n in ns])
    return out


def figure(table, png_path: Path | str) -> None:
    """Fig. 19: time per step against particle count, log-log, SF and DFG on
    each thread count (medians over the rounds; filled one thread, open
    more), with the least-squares power law of each as a dashed (dotted) line
    and its slope in the legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = medians(table)
    fig, ax = plt.subplots(figsize=(6.0, 4.5))
    markers, colours = {0: "o", 1: "s"}, {0: "C0", 1: "C3"}
    for d in (0, 1):
        for t in sorted({t for _, dd, t in m if dd == d}):
            ns = np.array([n for (n, dd, tt) in m if dd == d and tt == t], dtype=float)
            ts = np.array([m[(int(n), d, t)]["seconds"] for n in ns])
            slope = _slope(list(ns), list(ts))
            label = f"{METHODS[d].upper()}, {t} thread{'s' if t > 1 else ''}"
            line = ax.loglog(ns, 1e3 * ts, marker=markers[d], linestyle="none", color=colours[d],
                             fillstyle="full" if t == 1 else "none")[0]
            if slope is not None:
                fit = np.polyfit(np.log(ns), np.log(ts), 1)
                grid = np.geomspace(ns.min(), ns.max(), 20)
                ax.loglog(grid, 1e3 * np.exp(np.polyval(fit, np.log(grid))),
                          "--" if t == 1 else ":", color=colours[d], linewidth=0.8)
                label += f" (slope {slope:.2f})"
            line.set_label(label)
    ax.set_xlabel("particles $n_p$")
    ax.set_ylabel("wall time per step (ms)")
    ax.set_title("Cost of damage-gradient partitioning (H&H 2017, Fig. 19)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
