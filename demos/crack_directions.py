"""Where the cracks of a finished run went, against the weak directions of 1/G_c.

    python demos/crack_directions.py SCENE RUN_DIR [--set KEY=VALUE ...] [--history]

Reads the first and last particle snapshots of RUN_DIR (written by ``pfmpm
run SCENE --out RUN_DIR``), keeps the points that cracked during the run
(c < 0.2 at the end, not at the start), and prints, for each initial-crack
tip inside a body: the
direction in which the crack left it (``pfmpm.crack.propagation_angle`` over
2-10 l0 ahead of the tip), the crack arms crossing circles of growing radius
about it (``pfmpm.crack.crack_arms``: two arms ahead mean a branch), and the
weak directions of the body's G_c(theta) (``pfmpm.anisotropy.weak_directions``).
With ``--history``, also how the leaving direction develops: for every snapshot,
the direction of the new crack in rings of 1-4, 4-8, 8-16 and 16-28 l0 about the
tip (write snapshots often, e.g. ``--set output.every=160``).
"""

import argparse
import math
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import meshio
import numpy as np

from pfmpm.anisotropy import weak_directions
from pfmpm.crack import crack_arms, propagation_angle
from pfmpm.scene import Scene

THRESHOLD = 0.2


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("run_dir")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--history", action="store_true", help="the direction at every snapshot")
    args = parser.parse_args()
    scene = Scene.from_toml(args.scene, overrides=args.set)
    snapshots = sorted(Path(args.run_dir).glob("particles_*.vtu"))
    first, last = meshio.read(snapshots[0]), meshio.read(snapshots[-1])
    xy = last.points[:, :2]
    # Only what cracked during the run: the initial cracks' bands are left out.
    c0, c = first.point_data["c"].ravel(), last.point_data["c"].ravel()
    c = np.where(c0 < THRESHOLD, 1.0, c)
    print(f"{snapshots[-1].name}: {len(xy)} particles, {np.count_nonzero(c < THRESHOLD)} newly cracked"
          f" (c < {THRESHOLD})")
    body = next(b for b in scene.bodies if scene.fracture_of(b) is not None)
    fracture = scene.fracture_of(body)
    l0 = fracture.l0
    weak = weak_directions(fracture.gamma(), body.orientation)
    print("weak directions of 1/G_c:", ", ".join(f"{w:.1f}" for w in weak) or "none (isotropic)")
    x0, y0, x1, y1 = body.shape.bounds()
    for crack in scene.cracks:
        pts = np.asarray(crack.points, dtype=float)
        for tip, behind in ((pts[-1], pts[-2]), (pts[0], pts[1])):
            if not (x0 < tip[0] < x1 and y0 < tip[1] < y1):
                continue
            direction = (tip - behind) / np.linalg.norm(tip - behind)
            angle = propagation_angle(xy, c, tip, direction, 2 * l0, 10 * l0) % 360.0
            off = min(abs((w - angle + 180.0) % 360.0 - 180.0) for w in weak) if len(weak) else math.nan
            print(f"tip ({tip[0]:g}, {tip[1]:g}): crack left at {angle:.1f} deg"
                  f" ({off:.1f} deg from the nearest weak direction)")
            for radius in (5 * l0, 10 * l0, 20 * l0, 40 * l0):
                arms = [a for a in crack_arms(xy, c, tip, radius, scene.grid.h)
                        if math.cos(math.radians(a)) * direction[0]
                        + math.sin(math.radians(a)) * direction[1] > 0]
                print(f"  arms ahead at r = {radius:g}: " + (", ".join(f"{a:.1f}" for a in arms) or "none"))
            if args.history:
                history(Path(args.run_dir), c0, tip, direction, l0)


def history(run_dir: Path, c0: np.ndarray, tip, direction, l0: float) -> None:
    """Direction of the new crack about ``tip`` in rings of l0 units, snapshot by snapshot."""
    rings = ((1, 4), (4, 8), (8, 16), (16, 28))
    print("  t (us) | new crack direction (deg) at " + ", ".join(f"{a}-{b}" for a, b in rings) + " l0")
    for entry in ElementTree.parse(run_dir / "particles.pvd").iter("DataSet"):
        snap = meshio.read(run_dir / entry.get("file"))
        c = np.where(c0 < THRESHOLD, 1.0, snap.point_data["c"].ravel())
        angles = [propagation_angle(snap.points[:, :2], c, tip, direction, a * l0, b * l0)
                  for a, b in rings]
        print(f"  {float(entry.get('timestep')):6.1f} | " + ", ".join(f"{a:5.1f}" for a in angles))


if __name__ == "__main__":
    main()
