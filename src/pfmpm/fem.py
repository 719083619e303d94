"""Phase-field finite-element reference (PF-FEM) on DOLFINx.

The model and the step of the MPM path (:mod:`pfmpm.simulation`) on a fixed
finite-element mesh, so the PF-MPM results can be checked against the method
they claim to reproduce (K&T compare with PF-FEM the same way).

Discretisation
--------------
Mesh
    In 2D the body's rectangle in squares of side ``h = grid.h``, each cut into two
    right triangles by DOLFINx's ``left/right`` pattern: diagonal ``/`` in
    square ``(i, j)`` when ``i + j`` is even, ``\\`` when odd, counted from
    the body's lower-left corner.  The pattern is mirror symmetric about
    every second grid line, so a crack along such a line (the Borden plate's
    y = 20 is 80 h for h = 0.25) has the same mesh on both sides and a
    symmetric branching is not biased by it, as it is by the one-way
    ``right`` pattern.  It also has the larger explicit step of the two
    (0.80 against 0.69 h / c_p for nu = 0.2, lumped mass).  In 3D the body's
    box (a ``box``, or an ``extrusion`` of a rectangle) in cubes of side
    ``h``, each cut into six tetrahedra by ``dolfinx.mesh.create_box``; other
    3D shapes are refused with a one-line error.  Everything below is
    written once for both: triangles and tetrahedra are simplices with
    ``d + 1`` vertices and ``d + 1`` facets.
Fields
    Displacement ``u`` and phase field ``c`` are continuous P1.  Strain and
    stress are constant per cell, and so is the cell degradation, the
    exact cell mean of ``g(c)``.  In 3D strains and stresses are 3 x 3
    (columns xx, yy, xy, zz, yz, xz), split by the core's
    ``LinearElastic`` as the MPM's are.
History
    ``H`` (K&T eq. 20) lives at the three edge midpoints of each triangle, the
    points of the degree-2 midpoint rule, and the reaction term
    ``(F c, q)`` of K&T eq. (57) is integrated with that rule (see
    :class:`_PhaseFieldSolver`).  The strain is constant per triangle, so
    ``H = max(H, psi+)`` raises a cell's three points alike; without an
    initial crack ``H`` is constant per cell, where the rule is exact (the
    matrix of a cell-wise ``H`` integrated exactly).  An initial crack is
    Borden's history (:func:`pfmpm.crack.initial_history`) sampled at the
    midpoints, a quadrature of the band that converges at second order as
    the mesh resolves it.  A band narrower than a cell around a crack along
    mesh edges holds only the midpoints of those edges, where the basis
    functions of the vertices off the crack vanish: the crack's vertices go
    to ``c = 0`` and the next ones keep the free profile.  A value per cell
    (at its centroid, or its mean) or at interior Gauss points instead puts
    the band's large reaction on every vertex of the cells beside the crack,
    which the Galerkin solution then holds near 0 too: the crack came out a
    cell too wide on each side (1D profile, band h/2: max error
    0.45-0.48 h / l0 with the centroids, 0.003-0.006 h / l0 with the
    midpoints; tests/test_fem.py, docs/method.md).

    In 3D the points are the four face centroids of each tetrahedron (the
    facet centroids, as the edge midpoints are a triangle's), with the
    face-centroid rule (weights V/4; exact for degree 1 only, so a cell-wise
    ``H`` gives the exact row sums ``(F, N_I)`` but not the exact matrix).  A
    face off a crack plane along mesh faces has its centroid h/3 from the
    plane (an edge midpoint is h/2 off a crack line), so a band narrower than
    h/3 holds only the faces on the plane: at half-width h/4 the 1D profile
    is within 0.002-0.005 h / l0 of the exact one, at h/2 it is 0.46-0.48
    h / l0 off (tests/test_fem3d.py).
Elastodynamics
    Row-sum lumped mass; internal force from the cell stresses (K&T eq. 62 with
    cells in place of particles); tractions as consistent edge forces
    (half of ``t * length * thickness`` to each end of a loaded edge; in
    3D a third of ``t * area`` to each corner of a loaded face); body
    forces as ``M_I * b``.  Volumes, masses and forces include the
    thickness, as the MPM particle volumes do, so the energies compare.
Phase field
    K&T Eq. (47) without the fourth-order term, Galerkin on P1: the matrix
    ``K^c = L + M_F`` of K&T eq. (57) with ``L = 4 l0^2 (grad c, grad q)``
    assembled once and ``M_F = (F c, q)``, ``F`` of K&T eq. (49) at the history
    points, reassembled each step (about 25 % cheaper than reassembling the whole
    form: 16 against 21 ms for 128,000 cells); right-hand side
    ``F^c = (1, q)`` (K&T eq. 52).  AT1 (``fracture.model``, docs/method.md)
    changes ``F`` and ``F^c`` (:func:`_reaction`).  Both models are solved
    with the bound ``0 <= c <= 1`` unless ``fracture.bound = false``.

One step
--------
Scene step ``m`` does what the MPM step does, in the same order:

1. solve K&T eq. (56) with the current ``H``, warm-started from the previous
   ``c``, to ``||F^c - K^c c|| <= tol ||F^c||`` (``scene.phase_field.tol``);
2. degradation ``g = (1 - k_f) c^2 + k_f`` (K&T eq. 15) and the stress of
   ``g psi+ + psi-`` (K&T eqs. 14, 16) from ``pfmpm._core.LinearElastic``, the
   same code as the MPM;
3. ``v += dt M^-1 (f_ext - f_int)`` with walls, ``u += dt v`` (K&T eq. 60);
4. new strain, ``H = max(H, psi+)``.

The MPM step ``scene.dt()`` (``cfl * h / c_p`` for quadratic B-splines) is
above the P1 limit, so steps 2-4 run ``substeps`` times with
``dt / substeps``: the least number that keeps each sub-step below ``cfl``
times the element bound on the critical step (Irons & Treharne: no
eigenvalue of ``M_L^-1 K`` exceeds the largest element eigenvalue).  The
phase field is solved at the MPM times, once per scene step; ``H`` takes
the maximum over the sub-steps.

The phase-field system is solved by conjugate gradients with a Jacobi
preconditioner, inside PETSc's ``vinewtonrsls`` for the bound (see
``_PhaseFieldSolver``).  The reaction term keeps its condition number of order
``1 + (l0 / h)^2`` whatever the size of the mesh, so the iteration count
does not grow with it; Jacobi does not depend on how the mesh is
partitioned, so one and several MPI ranks take the same iterates up to
round-off; and it was the fastest of Jacobi, GAMG and BoomerAMG on the
Borden plate at h = 0.25, l0 = 0.5 (12, 30 and 150 ms a solve; about 50
iterations a step, warm-started).  PETSc options with the prefix
``pfmpm_pf_`` change it (e.g. ``PETSC_OPTIONS="-pfmpm_pf_pc_type hypre"``).

Run ``mpirun -n 4 python -m pfmpm.fem SCENE.toml --out DIR`` for a parallel
run; the energies match a serial run to round-off and the solver tolerance.
"""

from __future__ import annotations

import logging
import math
import sys
import warnings
from contextlib import contextmanager
from pathlib import Path

import basix.ufl_wrapper
import numpy as np
import ufl
from scipy import sparse
from dolfinx import fem, io, la, mesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from . import _core
from .crack import initial_history
from .run import SIDES, RunResult, energy_columns, region_columns, run_to_end, wall_columns
from .run_folder import check_fresh
from .scene import (Body, BodyForce, Box, Extrusion, LinearElasticSpec, MaterialSpec, Rectangle, Scene,
                    SceneError, Traction)
from .scene.loads import SIDE_NAME
from .scene.report import snapshot_warnings
from .simulation import core_materials

__all__ = ["FemSimulation", "MESH_DIAGONAL", "run_command", "main"]

#: DOLFINx diagonal pattern of the structured triangle mesh (see the module docstring).
MESH_DIAGONAL = mesh.DiagonalType.left_right

_ON_LINE = 1e-6  # a vertex lies on a line within this fraction of h
_WHOLE = 1e-9  # relative tolerance of "a whole number of cells"
#: The facet-centroid rule on the reference simplex, point k on the facet
#: opposite vertex k: the history points and the reaction's quadrature.  On
#: the triangle it is the edge-midpoint rule (degree 2); on the tetrahedron
#: the face-centroid rule (degree 1).
_FACET_RULE = {
    2: {"quadrature_rule": "custom", "quadrature_degree": 2,
        "quadrature_points": ((0.5, 0.5), (0.0, 0.5), (0.5, 0.0)),
        "quadrature_weights": (1 / 6, 1 / 6, 1 / 6)},
    3: {"quadrature_rule": "custom", "quadrature_degree": 1,
        "quadrature_points": ((1 / 3, 1 / 3, 1 / 3), (0.0, 1 / 3, 1 / 3), (1 / 3, 0.0, 1 / 3),
                              (1 / 3, 1 / 3, 0.0)),
        "quadrature_weights": (1 / 24, 1 / 24, 1 / 24, 1 / 24)},
}
#: The column of the stress or strain entry (i, j): in 2D xx, yy, xy (and
#: zz, the fourth stress column); in 3D xx, yy, xy, zz, yz, xz, the layout
#: of the core's symmetric tensors (cpp/pfmpm/common/symmetric.h).
_ENTRY = {2: ((0, 2), (2, 1)), 3: ((0, 2, 5), (2, 1, 4), (5, 4, 3))}
#: The cell types of the meshes.
_CELL = {2: "triangle", 3: "tetrahedron"}
_REGION = len(SIDES)  # a hold by region r is _REGION + r, one by a wall its side's index


class FemSimulation:
    """A one-body rectangular scene on a P1 triangle mesh, stepped like the MPM.

    Parameters
    ----------
    scene : Scene
        Exactly one body, a :class:`~pfmpm.scene.Rectangle` without holes
        whose edges lie on grid lines (multiples of ``grid.h`` from the grid
        origin).  Tractions, body forces, fixed and slip walls, initial
        cracks and the energy splits are supported.  A wall acts on the
        mesh vertices on its grid side; the body has to reach the side for
        it to matter.
    comm : mpi4py.MPI.Comm
        Communicator the mesh is distributed over.

    Attributes
    ----------
    scene : Scene
    comm : mpi4py.MPI.Comm
    mesh : dolfinx.mesh.Mesh
        The triangle mesh (no ghost cells).
    V : dolfinx.fem.FunctionSpace
        Scalar P1 space: ``c`` lives in it and each displacement component
        uses its dofs.
    c : dolfinx.fem.Function
        Phase field, 1 where intact.
    dt : float
        Scene time step ``scene.dt()``; one :meth:`advance` step is one dt.
    substeps : int
        Elastodynamic sub-steps per step.
    history : ndarray (cells, 3)
        History field ``H`` at the edge midpoints of the local cells, the
        midpoint of the edge opposite each vertex in the cell's vertex order.

    Raises
    ------
    SceneError
        If the scene is outside what the FEM path supports, naming the field.
    """

    checkpoints = False
    """The FEM path writes no checkpoints."""
    field_series = True
    """A run writes the XDMF series ``fields.xdmf`` (:meth:`open_frames`)."""

    def __init__(self, scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD):
        self.scene = scene
        self.comm = comm
        self._body, material = _supported(scene)
        self.dim = d = scene.dim
        self._box = _box_of(self._body.shape)
        self._fracture = material.fracture
        self._thickness = scene.thickness
        self.dt = scene.dt()
        self._step = 0
        self._work = 0.0  # external work of this rank's owned vertices
        self._wall_work = 0.0  # and the work of the walls on them
        self._wall_impulse = np.zeros((len(SIDES), d))  # and their impulses, per side
        n = len(scene.prescribed)  # the prescribed regions': work, impulse, displacement
        self._region_work = np.zeros(n)
        self._region_impulse, self._region_displacement = np.zeros((n, d)), np.zeros((n, d))
        with _quiet_jit():
            self._build_mesh()
            self._build_dynamics(material)
            self._build_phase_field()

    # -- set-up ---------------------------------------------------------------

    def _build_mesh(self) -> None:
        """Mesh, P1 space, cell-to-vertex map, cell gradients and sizes."""
        h, d = self.scene.grid.h, self.dim
        lo, hi = self._box
        self._cells_xy = tuple(round((b - a) / h) for a, b in zip(lo, hi))
        corners = [np.array(lo), np.array(hi)]
        if d == 2:
            self.mesh = mesh.create_rectangle(self.comm, corners, list(self._cells_xy), mesh.CellType.triangle,
                                              ghost_mode=mesh.GhostMode.none, diagonal=MESH_DIAGONAL)
        else:
            self.mesh = mesh.create_box(self.comm, corners, list(self._cells_xy), mesh.CellType.tetrahedron,
                                        ghost_mode=mesh.GhostMode.none)
        self.V = fem.FunctionSpace(self.mesh, ("Lagrange", 1))
        imap = self.V.dofmap.index_map
        self._owned = imap.size_local
        self._local = imap.size_local + imap.num_ghosts
        n_cells = self.mesh.topology.index_map(d).size_local
        nv = d + 1
        self._dofs = self.V.dofmap.list.array.reshape(-1, nv)[:n_cells]
        self._flat_dofs = self._dofs.ravel()
        # Vertex coordinates from the mesh geometry (P1 dofs sit on the vertices in
        # the cell's vertex order): exact, where tabulated dof coordinates carry
        # round-off that depends on the partition.
        geometry = self.mesh.geometry
        self._x = np.empty((self._local, d))
        self._x[self._flat_dofs] = geometry.x[geometry.dofmap.array.reshape(-1, nv)[:n_cells].ravel(), :d]
        corners = self._x[self._dofs]  # (cells, d + 1, d)
        jac = np.stack([corners[:, k + 1] - corners[:, 0] for k in range(d)], axis=2)
        if d == 2:  # the inverse written out, as it was before the 3D mesh: the same bits
            det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
            inv = np.stack([np.stack([jac[:, 1, 1], -jac[:, 0, 1]], axis=1),
                            np.stack([-jac[:, 1, 0], jac[:, 0, 0]], axis=1)], axis=1) / det[:, None, None]
        else:
            det, inv = np.linalg.det(jac), np.linalg.inv(jac)
        ref_grad = np.vstack([-np.ones(d), np.eye(d)])  # grad of the P1 basis on the reference cell
        grad = np.einsum("ak,ckj->caj", ref_grad, inv)  # grad N_a on each cell
        self._grad = [grad[..., k].copy() for k in range(d)]  # per direction, (cells, d + 1)
        self._area = np.abs(det) / math.factorial(d)  # area or volume of each cell
        self._square_mean = float((d + 1) * (d + 2))  # the cell mean of f^2 for P1 f: (sum^2 + sum of squares) / this
        self._volume = self._area * self._thickness
        # Where the history lives: the centroid of the facet opposite each
        # vertex (the edge midpoints of a triangle), the order of the
        # Crouzeix-Raviart dofs that carry the reaction.
        opposite = [[(k + j) % nv for j in range(1, nv)] for k in range(nv)]
        self._midpoints = np.stack([corners[:, o].sum(axis=1) / d for o in opposite], axis=1)  # (cells, d+1, d)
        # d/dx_k of a P1 field on each cell as sparse (cells x vertices)
        # matrices, and their transposes, which gather cell fluxes to vertices.
        rows = np.repeat(np.arange(n_cells), nv)
        shape = (n_cells, self._local)
        self._D = [sparse.csr_matrix((g.ravel(), (rows, self._flat_dofs)), shape=shape) for g in self._grad]
        self._D_t = [D.T.tocsr() for D in self._D]

    def _build_dynamics(self, material: MaterialSpec) -> None:
        """Material, lumped mass, external force, walls and the initial state."""
        scene, d = self.scene, self.dim
        core = core_materials(scene)[0][scene.materials.index(material)]
        self._elastic = core  # its splits take (N, 3) or (N, 6) strains
        imap = self.V.dofmap.index_map
        self._u = la.vector(imap, bs=d)  # displacement, ghosts kept current
        self._scratch = la.vector(imap, bs=d)  # assembly buffer for nodal vectors
        self._density = material.density
        weights = np.repeat(material.density * self._volume / float(d + 1), d + 1)
        self._mass = self._assemble(np.bincount(self._flat_dofs, weights, self._local), scalar=True)
        self._loads = self._load_forces()
        self._fext = self._external_force(0.0)
        self._holds = self._hold_masks()
        self._v = np.tile(np.asarray(self._body.velocity, dtype=float), (self._owned, 1))
        self._eps = np.zeros((len(self._dofs), 3 * d - 3))  # xx, yy, xy (, zz, yz, xz)
        self.substeps = self._substeps()

    def _build_phase_field(self) -> None:
        """Phase field, initial history and, if the material can crack, its solver.

        Raises
        ------
        SceneError
            If an initial crack's band holds no edge midpoint of the mesh, so
            that it would not be imposed at all.
        """
        self.c = fem.Function(self.V, name="c")
        self.c.x.array[:] = 1.0
        self._g = np.ones(len(self._dofs))
        nv = self.dim + 1
        self.history = np.zeros((len(self._dofs), nv))
        self._pf = None
        if self._fracture is None:
            return
        points = self._midpoints.reshape(-1, self.dim)
        for index, crack in enumerate(self.scene.cracks):
            if crack.body not in (None, self._body.name):
                continue
            seed = initial_history(points, crack, self._fracture).reshape(-1, nv)
            if not self.comm.allreduce(bool(np.any(seed > 0.0)), op=MPI.LOR):
                w = crack.half_width if crack.half_width is not None else 0.5 * self._fracture.l0
                h = self.scene.grid.h
                what = "edge midpoint" if self.dim == 2 else "face centroid"
                raise SceneError(f"cracks[{index}].half_width", f"the crack's band holds no {what}"
                                 f" of the FEM mesh (h = {h:g}), so it would not be"
                                 " imposed: widen it or move the crack onto the body", w)
            np.maximum(self.history, seed, out=self.history)
        self._pf = _PhaseFieldSolver(self.c, self._fracture, self.scene.phase_field, len(self._dofs), self.dim)
        self._solve_phase_field()  # the phase field of the initial cracks, as the MPM

    def _assemble(self, local: np.ndarray, scalar: bool = False) -> np.ndarray:
        """Sum cell contributions across ranks; return the owned vertex values.

        ``local`` holds this rank's contributions to its local vertices
        (owned then ghost), shape (local,) or (local, dim).
        """
        vec = la.vector(self.V.dofmap.index_map, bs=1) if scalar else self._scratch
        vec.array[:] = local.ravel()
        vec.scatter_reverse(la.ScatterMode.add)
        values = vec.array.reshape(-1) if scalar else vec.array.reshape(-1, self.dim)
        return values[: self._owned].copy()

    def _load_forces(self) -> list[tuple]:
        """Each load on the body and its force on the owned vertices (owned, dim)
        at amplitude 1.

        Tractions: each cell facet (edge of a triangle, face of a
        tetrahedron) on the loaded side of the body's box (with a ``span``,
        whose midpoint, or centroid in 3D, lies in it: a span that holds
        none is a SceneError) gives ``t * size * thickness / dim`` to each
        of its vertices, the consistent P1 load (K&T eq. 17); a facet lies
        on the boundary of one cell only, so every facet counts once over
        all ranks.  Body forces: ``M_I b``.
        """
        d, nv = self.dim, self.dim + 1
        planes = self._planes(self._box)
        tol = _ON_LINE * self.scene.grid.h
        forces = []
        # The facets of a cell by their vertices, (0, 1), (1, 2), (2, 0) of a triangle.
        facets = [[(j + k) % nv for k in range(d)] for j in range(nv)]
        for i, load in enumerate(self.scene.loads):
            if isinstance(load, BodyForce):
                if load.body in (None, self._body.name):
                    forces.append((load, self._mass[:, None] * np.asarray(load.acceleration)))
                continue
            f = np.zeros((self._local, d))
            loaded = 0  # facets in the span
            axis, value = planes[load.edge]
            on = np.abs(self._x[self._dofs, axis] - value) <= tol  # (cells, d + 1)
            for facet in facets:
                ends = [self._dofs[np.all(on[:, facet], axis=1), a] for a in facet]
                if load.span is not None:
                    centre = sum(self._x[e] for e in ends) / d  # the facet's midpoint (2D) or centroid (3D)
                    inside = np.ones(len(centre), dtype=bool)
                    for along, a, b in load.patch():
                        inside &= (centre[:, along] >= a) & (centre[:, along] <= b)
                    ends = [e[inside] for e in ends]
                loaded += len(ends[0])
                if d == 2:
                    size = np.hypot(*(self._x[ends[1]] - self._x[ends[0]]).T)
                else:
                    normal = np.cross(self._x[ends[1]] - self._x[ends[0]], self._x[ends[2]] - self._x[ends[0]])
                    size = 0.5 * np.sqrt(np.einsum("ij,ij->i", normal, normal))
                share = size * self._thickness / d
                for k in range(d):
                    for e in ends:
                        f[:, k] += np.bincount(e, share * load.traction[k], self._local)
            if load.span is not None and not self.comm.allreduce(loaded, op=MPI.SUM):
                what = "the midpoint of no cell edge" if d == 2 else "the centroid of no cell face"
                raise SceneError(f"loads[{i}].span", f"holds {what} of the FEM mesh"
                                                     f" on the {load.edge} {SIDE_NAME[d]} of body {load.body!r}",
                                 load.span)
            forces.append((load, self._assemble(f)))
        return forces

    @staticmethod
    def _planes(box) -> dict[str, tuple[int, float]]:
        """The sides of a box ``(min, max)`` as (axis, coordinate), by name."""
        (lo, hi), names = box, ("left", "right", "bottom", "top", "back", "front")
        return {names[2 * k + j]: (k, (lo, hi)[j][k]) for k in range(len(lo)) for j in range(2)}

    def _external_force(self, t: float) -> np.ndarray:
        """External force on the owned vertices at time ``t`` (owned, dim): each
        load's times its amplitude then (:meth:`_load_forces`)."""
        fext = np.zeros((self._owned, self.dim))
        for load, force in self._loads:
            fext += (1.0 if load.amplitude is None else load.amplitude(t)) * force
        return fext

    def _hold_masks(self) -> list[tuple[int, np.ndarray, int]]:
        """What the prescribed regions and the walls hold, as the MPM's grid
        does: (holder, owned vertices, component), the holder a side (a wall)
        or ``_REGION`` + the index of a region; each vertex's component once, by a
        region first (the vertices in its box, on its body's face or of its
        body), then by the wall it is normal to, then by a fixed wall's
        tangential hold."""
        d, grid = self.dim, self.scene.grid
        line = self._planes((grid.origin, tuple(o + s for o, s in zip(grid.origin, grid.size))))
        tol = _ON_LINE * grid.h
        x = self._x[: self._owned]
        candidates = []
        faces = self._planes(self._box)
        for r, region in enumerate(self.scene.prescribed):
            if region.box:
                inside = np.all((x >= np.subtract(region.min, tol)) & (x <= np.add(region.max, tol)), axis=1)
            elif region.face is not None:  # the vertices on that side of the body
                axis, value = faces[region.face]
                inside = np.abs(x[:, axis] - value) <= tol
            else:  # the whole body
                inside = np.ones(len(x), dtype=bool)
            candidates += [(_REGION + r, inside, k) for k in range(d) if region.mask & (1 << k)]
        for normal in (True, False):
            for w in self.scene.walls:
                axis, value = line[w.side]
                if normal or w.type == "fixed":
                    on = np.abs(x[:, axis] - value) <= tol
                    candidates += [(SIDES.index(w.side), on, k) for k in range(d)
                                   if (k == axis) == normal]
        held = np.zeros((self._owned, d), dtype=bool)
        masks = []
        for holder, on, k in candidates:
            on = on & ~held[:, k]
            held[on, k] = True
            masks.append((holder, on, k))
        return masks

    def _substeps(self) -> int:
        """Sub-steps per scene step so each is below ``cfl`` times the critical step.

        The critical step is ``2 / sqrt(lambda_max)`` with ``lambda_max``
        the largest eigenvalue of ``M_e^-1 K_e`` over the elements, with the
        undegraded material (degradation only softens, as ``psi+`` is
        convex), an upper bound of that of the assembled ``M_L^-1 K``
        (Irons & Treharne 1971).  The eigenvalues of the distinct cell
        shapes are enough (two on the structured mesh).
        """
        d, nv = self.dim, self.dim + 1
        n = self._eps.shape[1]  # strain entries
        # Columns of the undegraded stiffness: stress of unit strains (xx, yy, xy, ...).
        unit = self._elastic.stresses(np.eye(n), np.ones(n))[:, :n].T  # (stress, strain)
        # sigma : eps = s_xx e_xx + ... + 2 s_xy e_xy + ...
        weight = np.array([1.0 if i == j else 2.0 for i, j in _entries(d)])
        h = self.scene.grid.h
        shapes = np.unique(np.round(np.hstack(self._grad) * h, 12), axis=0) / h
        grads = [shapes[:, k * nv:(k + 1) * nv] for k in range(d)]
        b = np.zeros((len(shapes), n, d * nv))  # strain from the d components of the nv vertices
        for e, (i, j) in enumerate(_entries(d)):
            if i == j:
                b[:, e, i::d] = grads[i]
            else:
                b[:, e, i::d] = 0.5 * grads[j]
                b[:, e, j::d] = 0.5 * grads[i]
        stiff = np.einsum("cki,k,kl,clj->cij", b, weight, unit, b)  # K_e / area
        lam = np.linalg.eigvalsh(stiff).max(axis=1).max(initial=0.0) * float(nv) / self._density
        lam = self.comm.allreduce(lam, op=MPI.MAX)
        dt_crit = 2.0 / math.sqrt(lam)
        return max(1, math.ceil(self.dt / (self.scene.time.cfl * dt_crit) * (1 - _WHOLE)))

    # -- state ----------------------------------------------------------------

    def columns(self, observed: list[str] = ()) -> list[str]:
        """Columns of ``energies.csv`` for this scene, then the columns
        ``observed`` of the run's observers (:meth:`pfmpm.observe.Observer.columns`)."""
        d = self.dim
        return (energy_columns(d) + wall_columns(self.scene.walls, d) + region_columns(self.scene.prescribed, d)
                + list(observed))

    @property
    def cracks(self) -> bool:
        """Whether the body can crack (its material has a fracture table)."""
        return self._pf is not None

    @property
    def step(self) -> int:
        """Scene steps taken."""
        return self._step

    @property
    def time(self) -> float:
        """Simulated time ``step * dt``."""
        return self._step * self.dt

    @property
    def displacement(self) -> np.ndarray:
        """Displacement of the local vertices (owned then ghost), (local, dim) view."""
        return self._u.array.reshape(-1, self.dim)

    @property
    def velocity(self) -> np.ndarray:
        """Velocity of the owned vertices, (owned, dim) view."""
        return self._v

    @property
    def vertices(self) -> np.ndarray:
        """Coordinates of the local vertices (owned then ghost), (local, dim)."""
        return self._x

    @property
    def owned(self) -> int:
        """Number of vertices this rank owns (the first ones of the local arrays)."""
        return self._owned

    @property
    def lumped_mass(self) -> np.ndarray:
        """Row-sum lumped mass of the owned vertices, (owned,)."""
        return self._mass

    @property
    def external_force(self) -> np.ndarray:
        """External force on the owned vertices in the last sub-step, (owned, dim) view."""
        return self._fext

    @property
    def phase_field_stats(self) -> dict[str, int]:
        """Phase-field solves and CG iterations so far."""
        return dict(self._pf.stats) if self._pf is not None else {"solves": 0, "iterations": 0}

    # -- stepping -------------------------------------------------------------

    def advance(self, steps: int) -> None:
        """Take ``steps`` scene steps (phase field, then the elastodynamic sub-steps)."""
        h = self.dt / self.substeps
        amplified = any(load.amplitude is not None for load, _ in self._loads)
        for _ in range(steps):
            self._solve_phase_field()
            for k in range(self.substeps):
                if amplified:  # the loads at the sub-step's midpoint, as the MPM's
                    self._fext = self._external_force(self.time + (k + 0.5) * h)
                self._substep(self.time + k * h, h)
            self._step += 1

    def _solve_phase_field(self) -> None:
        """Solve K&T eq. (47) with the current history and update the cell degradation."""
        if self._pf is not None:
            self._pf.solve(self.history, self._step, self.time)
            self._g = self._degradation()

    def _degradation(self) -> np.ndarray:
        """Cell mean of ``g = (1 - k_f) c^2 + k_f`` (K&T eq. 15), exact for P1 ``c``."""
        ce = self.c.x.array[self._dofs]
        mean_sq = (ce.sum(axis=1) ** 2 + (ce * ce).sum(axis=1)) / self._square_mean
        k_f = self._fracture.k_f
        return (1.0 - k_f) * mean_sq + k_f

    def _strain(self) -> np.ndarray:
        """Cell strains (cells, 3) in 2D: xx, yy and the tensor xy component
        (K&T eq. 2); (cells, 6) in 3D: xx, yy, xy, zz, yz, xz."""
        u = self._u.array.reshape(-1, self.dim)
        comp = [np.ascontiguousarray(u[:, k]) for k in range(self.dim)]
        eps = np.empty_like(self._eps)
        for e, (i, j) in enumerate(_entries(self.dim)):
            eps[:, e] = self._D[i] @ comp[i] if i == j else 0.5 * (self._D[j] @ comp[i] + self._D[i] @ comp[j])
        return eps

    def stresses(self) -> np.ndarray:
        """Cell stresses of ``g psi+ + psi-`` (K&T eqs. 14-16): (cells, 4) in
        2D, xx, yy, xy, zz; (cells, 6) in 3D, xx, yy, xy, zz, yz, xz."""
        return self._elastic.stresses(self._eps, self._g)

    def _internal_force(self) -> np.ndarray:
        """Internal force on the owned vertices (owned, dim), K&T eq. (62) over cells."""
        sig = self.stresses() * self._volume[:, None]
        entry = _ENTRY[self.dim]
        f = np.empty((self._local, self.dim))
        for i in range(self.dim):
            f[:, i] = self._D_t[0] @ sig[:, entry[i][0]]
            for j in range(1, self.dim):
                f[:, i] += self._D_t[j] @ sig[:, entry[i][j]]
        return self._assemble(f)

    def _substep(self, t: float, dt: float) -> None:
        """One explicit step from ``t``: momentum (K&T eq. 60), prescribed regions
        and walls, position, strain, history."""
        fint = self._internal_force()
        v_old = self._v.copy()
        self._v += dt * (self._fext - fint) / self._mass[:, None]
        held = [region.velocity_over(t, dt) for region in self.scene.prescribed]
        for r, region in enumerate(self.scene.prescribed):
            self._region_displacement[r] += dt * np.array([held[r][k] if region.mask & (1 << k) else 0.0
                                                           for k in range(self.dim)])
        for holder, on, k in self._holds:
            # As the MPM's holders: the impulse is the momentum added; a
            # wall's work the kinetic energy stopped, a region's the kinetic
            # energy it adds less the work of the forces it balances.
            m, vo, vn = self._mass[on], v_old[on, k], self._v[on, k]
            if holder < _REGION:
                self._wall_work -= 0.5 * float(m @ (vo ** 2))
                self._wall_impulse[holder, k] -= float(m @ vn)
                self._v[on, k] = 0.0
            else:
                u = held[holder - _REGION][k]
                self._region_work[holder - _REGION] += float(m @ (0.5 * (u * u - vo ** 2) - (vn - vo) * u))
                self._region_impulse[holder - _REGION, k] += float(m @ (u - vn))
                self._v[on, k] = u
        self._work += 0.5 * dt * float(np.sum(self._fext * (v_old + self._v)))
        u = self._u.array.reshape(-1, self.dim)
        u[: self._owned] += dt * self._v
        self._u.scatter_forward()
        self._eps = self._strain()
        if self._pf is not None:
            psi_plus, _ = self._elastic.split_energies(self._eps)
            np.maximum(self.history, psi_plus[:, None], out=self.history)  # K&T eq. (20)

    # -- diagnostics ----------------------------------------------------------

    def energies(self) -> dict[str, float]:
        """Energies and momentum now, with the keys of ``ENERGY_COLUMNS``.

        Sums run over owned vertices and cells and are reduced over the
        communicator, so every rank gets the same values.  ``elastic`` is
        ``sum V (g psi+ + psi-)`` (K&T eq. 14), ``fracture`` the crack density
        functional ``G_c int Z dV`` (K&T eqs. 3-4 with no anisotropy, or AT1's
        density, see :meth:`_fracture_energy`), exact for P1 ``c``.
        """
        psi_plus, psi_minus = self._elastic.split_energies(self._eps)
        m, v, axes = self._mass, self._v, "xyz"[:self.dim]
        momenta = [float(m @ v[:, k]) for k in range(self.dim)]
        if self.dim == 3:  # and the angular momentum about the origin, sum m x cross v
            x = self._x[: self._owned] + self.displacement[: self._owned]
            momenta += [float(m @ a) for a in np.cross(x, v).T]
        local = np.array([
            0.5 * float(np.sum(m * np.einsum("ij,ij->i", v, v))),
            float(self._volume @ (self._g * psi_plus + psi_minus)),
            self._fracture_energy(),
            self._work,
            self._wall_work,
            *momenta,
        ])
        kinetic, elastic, fracture, work, wall, *momenta = self.comm.allreduce(local, op=MPI.SUM)
        impulse = self.comm.allreduce(self._wall_impulse, op=MPI.SUM)
        walls = {f"impulse_{w.side}_{d}": float(impulse[SIDES.index(w.side), k])
                 for w in self.scene.walls for k, d in enumerate(axes)}
        region_work = self.comm.allreduce(self._region_work, op=MPI.SUM)
        region_impulse = self.comm.allreduce(self._region_impulse, op=MPI.SUM)
        for r, region in enumerate(self.scene.prescribed):
            walls[f"work_{region.name}"] = float(region_work[r])
            for k, d in enumerate(axes):
                walls[f"impulse_{region.name}_{d}"] = float(region_impulse[r, k])
                walls[f"displacement_{region.name}_{d}"] = float(self._region_displacement[r, k])
        names = [f"momentum_{d}" for d in axes] + [f"angular_momentum_{d}" for d in axes if self.dim == 3]
        walls |= dict(zip(names, momenta))
        return walls | {
            "step": self._step,
            "t": self.time,
            "kinetic": kinetic,
            "elastic": elastic,
            "fracture": fracture,
            "external_work": work,
            "wall_work": wall,
            "total": kinetic + elastic + fracture - work - wall - float(np.sum(region_work)),
        }

    def _fracture_energy(self) -> float:
        """This rank's ``G_c int Z dV`` (K&T eq. 4, gamma = 0), exact for P1 ``c``.

        AT2: ``Z = (1 - c)^2 / (4 l0) + l0 |grad c|^2``; AT1:
        ``Z = 3 (1 - c) / (16 l0) + (3/4) l0 |grad c|^2`` (the C++
        ``Fracture::crack_density``).
        """
        if self._fracture is None:
            return 0.0
        return self._fracture.Gc * self._crack_area()

    def _crack_area(self) -> float:
        """This rank's ``int Z dV``, the crack surface area of the phase field
        (the fracture energy over G_c), exact for P1 ``c``: see
        :meth:`_fracture_energy`.  In 2D a volume integral includes the
        thickness."""
        ce = self.c.x.array[self._dofs]
        w = 1.0 - ce
        grad = [np.einsum("ca,ca->c", ce, g) for g in self._grad]
        grad2 = grad[0] * grad[0] + grad[1] * grad[1]
        if self.dim == 3:
            grad2 += grad[2] * grad[2]
        l0 = self._fracture.l0
        if self._fracture.model == "AT1":
            density = 3.0 * w.mean(axis=1) / (16.0 * l0) + 0.75 * l0 * grad2
        else:
            mean_sq = (w.sum(axis=1) ** 2 + (w * w).sum(axis=1)) / self._square_mean  # cell mean of (1 - c)^2
            density = mean_sq / (4.0 * l0) + l0 * grad2
        return float(self._volume @ density)

    def crack_area(self) -> float:
        """The crack surface area ``int Z dV`` of the phase field over the mesh
        (collective: the same on every rank), the 3D form of the crack length:
        the fracture energy over G_c (:meth:`_crack_area`); 0 where nothing
        can crack."""
        return self.comm.allreduce(self._crack_area() if self._fracture is not None else 0.0, op=MPI.SUM)

    def crack_points(self) -> tuple[np.ndarray, np.ndarray]:
        """This rank's owned vertices and their phase field, which the crack
        tip, the crack path and the phase-field images of :mod:`pfmpm.observe`
        watch (the ranks' tips are merged with
        :meth:`~pfmpm.observe.CrackTip.merge`, so they do not depend on how
        the mesh is partitioned)."""
        return self._x[: self._owned], self.c.x.array[: self._owned]

    def crack_ids(self) -> np.ndarray:
        """The ids of the points of :meth:`crack_points`, in their order: the
        owned vertices' global indices, by which the crack path keeps them."""
        return np.arange(*self.V.dofmap.index_map.local_range, dtype=np.int64)

    # -- run with output ------------------------------------------------------

    def run(self, out_dir: Path | str, progress: bool = True, overwrite: bool = False,
            observers=None) -> RunResult:
        """Run to ``scene.time.end``, writing output to ``out_dir`` (collective).

        The run loop of :func:`pfmpm.run.run_to_end`, with its folder rules
        (``overwrite``): rank 0 writes ``scene.toml``,
        ``energies.csv``, ``summary.json`` and the plots; all ranks write the
        XDMF series ``fields.xdmf`` (:meth:`open_frames`) every
        ``output.every`` steps (and at the start and the end).  A non-finite energy stops the
        run with status ``"failed"`` and an error naming the step and time;
        Ctrl-C or SIGTERM stops every rank at the same step with status
        ``"interrupted"``.  Output written so far stays.  ``observers``: see
        :func:`~pfmpm.run.run_to_end`.
        """
        return run_to_end(self, out_dir, progress, overwrite=overwrite, observers=observers)

    # -- what the run loop of pfmpm.run asks of a simulation -----------------

    def open_frames(self, out: Path, entries=()) -> "_XdmfFrames":
        """The XDMF series ``fields.xdmf`` on the mesh (collective): phase field,
        displacement, velocity, stress and history (see :class:`_XdmfFrames`);
        a new one (``entries`` are for a resumed run, which the FEM has not)."""
        return _XdmfFrames(self, out / "fields.xdmf")

    def snapshot_pixels(self) -> tuple[float, np.ndarray, tuple[int, int], float]:
        """The pixels of the phase-field images, like the MPM's
        (``output.snapshots``): one pixel centred on each vertex."""
        h, (nx, ny) = self.scene.grid.h, self.scene.grid.cells  # 2D only (a 3D scene has no snapshots)
        return h, np.asarray(self.scene.grid.origin, dtype=float) - 0.5 * h, (nx + 1, ny + 1), 0.5 * h

    def summary(self) -> dict:
        """Sizes and settings of the discretisation (global over ranks)."""
        vertices = self.V.dofmap.index_map.size_global
        return {
            "method": "fem",
            "ranks": self.comm.size,
            "vertices": vertices,
            "cells": self.mesh.topology.index_map(self.dim).size_global,
            "dofs": (self.dim + 1) * vertices if self._pf is not None else self.dim * vertices,
            "mesh": {"cells": list(self._cells_xy), "h": self.scene.grid.h}
            | ({"diagonal": "left/right"} if self.dim == 2 else {"cell": "tetrahedron", "per_cube": 6}),
            "dt": self.dt,
            "substeps": self.substeps,
        }

    def summary_fields(self, result: RunResult) -> dict:
        """The FEM entries of ``summary.json``: :meth:`summary`, the end time and
        the phase-field solver's statistics."""
        fields = {**self.summary(), "t_end": self.time}
        if self._pf is not None:
            stats = self.phase_field_stats
            stats["mean_iterations"] = stats["iterations"] / max(stats["solves"], 1)
            stats["solver"] = self._pf.solver
            fields["phase_field"] = stats
        return fields


class _XdmfFrames:
    """The XDMF series of a FEM run (collective): ``write()`` adds, at the
    current time, the phase field ``c``, the displacement and the velocity
    (vertex values), and the stress and the history field ``H`` (cell values:
    the mean of a cell's facet-centroid values, the facet rule's cell mean).
    In 2D the stress is the in-plane 2 x 2 tensor (which XDMF pads to 3 x 3
    with zeros) and its out-of-plane entry ``stress_zz`` apart (DOLFINx 0.5
    writes a cell-wise tensor as cell data only if it is gdim x gdim); in 3D
    the 3 x 3 tensor."""

    def __init__(self, sim: FemSimulation, path: Path):
        self._sim = sim
        msh = sim.mesh
        with _quiet_jit():
            vector = fem.VectorFunctionSpace(msh, ("Lagrange", 1))
            cells = fem.FunctionSpace(msh, ("DG", 0))
            tensor = fem.TensorFunctionSpace(msh, ("DG", 0))
        self._u = fem.Function(vector, name="displacement")
        self._v = fem.Function(vector, name="velocity")
        self._stress = fem.Function(tensor, name="stress")
        self._zz = fem.Function(cells, name="stress_zz") if sim.dim == 2 else None
        self._history = fem.Function(cells, name="history")
        n_cells = len(sim.history)
        self._cell_dof = cells.dofmap.list.array[:n_cells]
        # Where each stress entry (xx, yy, xy, ...) goes in the row-major d x d tensor.
        d = sim.dim
        block = tensor.dofmap.index_map_bs * tensor.dofmap.list.array[:n_cells]
        self._stress_dofs = [block[:, None] + np.array(sorted({i * d + j, j * d + i}))
                             for i, j in _entries(d)]
        self._file = io.XDMFFile(sim.comm, str(path), "w")
        self._file.write_mesh(msh)

    def write(self) -> None:
        sim, t = self._sim, self._sim.time
        self._u.x.array[:] = sim.displacement.ravel()
        self._v.x.array[: sim.dim * sim.owned] = sim.velocity.ravel()
        self._v.x.scatter_forward()
        sigma = sim.stresses()
        for k, dofs in enumerate(self._stress_dofs):
            self._stress.x.array[dofs] = sigma[:, k, None]
        if self._zz is not None:
            self._zz.x.array[self._cell_dof] = sigma[:, 3]
        self._history.x.array[self._cell_dof] = sim.history.mean(axis=1)
        for function in (sim.c, self._u, self._v, self._stress, self._zz, self._history):
            if function is not None:
                self._file.write_function(function, t)

    def close(self) -> None:
        self._file.close()


class _PhaseFieldSolver:
    """K&T Eq. (47) without the fourth-order term on P1, solved for ``c`` in place.

    ``K^c c = F^c`` (K&T eq. 56) with ``K^c = L + M_F`` (K&T eq. 57, cells for
    particles): ``L_IJ = 4 l0^2 (grad N_J, grad N_I)``,
    ``M_F,IJ = (F N_J, N_I)`` with the reaction ``F`` of :func:`_reaction`
    at the history points, and ``F^c_I = s (1, N_I)`` (K&T eq. 52) with
    ``s = 1`` (AT2) or ``1/2`` (AT1).  ``M_F`` is integrated with the facet
    centroid rule (``sum_k V/(d+1) F_k N_I(m_k) N_J(m_k)`` over the centroids
    ``m_k`` of the facets of a cell of size ``V``: in 2D the edge-midpoint
    rule, exact for ``F`` constant per cell; in 3D the face-centroid rule,
    exact for the row sums ``(F, N_I)`` and consistent at second order);
    ``F`` is held by a discontinuous Crouzeix-Raviart function, whose dofs
    are its values at the facet centroids.  ``L`` and ``F^c`` are assembled
    once; each solve reassembles ``M_F`` into the same sparsity pattern and
    adds ``L``.

    With ``fracture.bound`` (the default, and always for AT1) it is solved
    with the bound ``0 <= c <= 1`` by PETSc's variational-inequality Newton
    method ``vinewtonrsls`` (reduced-space active set): the residual
    ``K^c c - F^c`` is linear, so each Newton step is one CG solve on the free
    vertices with the held ones fixed, and the steps stop when the active set
    settles and ``||F^c - K^c c||`` over the free vertices is at most
    ``tol ||F^c||``, the criterion of the MPM's bounded solve.  AT2's first
    solve starts from the unbounded CG solution.  Without the bound (AT2 with
    ``bound = false``), by PETSc's CG alone.

    Parameters
    ----------
    c : dolfinx.fem.Function
        P1 phase field; solved in place, warm-starting from its value.
    fracture : pfmpm.scene.FractureSpec
    settings : pfmpm.scene.PhaseFieldSpec
        Tolerance on ``||F^c - K^c c|| / ||F^c||`` and the iteration limit
        (of the CG iterations of one solve, and of its Newton steps).
    n_cells : int
        Number of local cells (the history array's rows).
    dim : int
        The mesh's dimension: 2 (triangles) or 3 (tetrahedra).
    """

    def __init__(self, c: fem.Function, fracture, settings, n_cells: int, dim: int = 2):
        V = c.function_space
        msh = V.mesh
        self.c = c
        self._fracture = fracture
        self._tol = settings.tol
        # Discontinuous Crouzeix-Raviart: dof k of a cell is the value at the
        # centroid of the facet opposite vertex k.
        W = fem.FunctionSpace(msh, basix.ufl_wrapper.create_element("CR", _CELL[dim], 1,
                                                                    discontinuous=True))
        self._point_dof = W.dofmap.list.array.reshape(-1, dim + 1)[:n_cells]
        self._reaction = fem.Function(W)
        p, q = ufl.TrialFunction(V), ufl.TestFunction(V)
        ell2 = fem.Constant(msh, PETSc.ScalarType(4.0 * fracture.l0 ** 2))
        laplace = fem.form(ell2 * ufl.inner(ufl.grad(p), ufl.grad(q)) * ufl.dx)
        self._L = fem_petsc.assemble_matrix(laplace)
        self._L.assemble()
        self._mass_form = fem.form(self._reaction * p * q * ufl.dx(metadata=_FACET_RULE[dim]))
        self._M = fem_petsc.create_matrix(self._mass_form)
        self._A = self._L.duplicate(copy=True)
        self._b = fem_petsc.assemble_vector(fem.form(q * ufl.dx))
        self._b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if fracture.model == "AT1":
            self._b.scale(0.5)  # AT1's source (Fracture::source), exact in binary
        # CG on K^c c = F^c: AT2's solver without the bound, and with it the
        # first guess of the first solve (below).
        self._plain = self._cg(msh.comm, settings) if fracture.model == "AT2" else None
        self.bounded = fracture.bound  # always for AT1 (the scene checks)
        if self.bounded:
            self._snes = self._bounded_solver(msh.comm, settings)
        self._ksp = self._snes.getKSP() if self.bounded else self._plain
        self.stats = {"solves": 0, "iterations": 0, "last_iterations": 0}
        if self.bounded:
            self.stats.update({"passes": 0, "last_passes": 0})

    def _cg(self, comm, settings) -> PETSc.KSP:
        """Jacobi-preconditioned CG for ``K^c c = F^c``, warm-started from ``c``."""
        ksp = PETSc.KSP().create(comm)
        ksp.setOptionsPrefix("pfmpm_pf_")
        ksp.setOperators(self._A)
        ksp.setType(PETSc.KSP.Type.CG)
        ksp.getPC().setType(PETSc.PC.Type.JACOBI)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setTolerances(rtol=settings.tol, atol=0.0, max_it=settings.max_iterations)
        ksp.setInitialGuessNonzero(True)
        ksp.setFromOptions()
        return ksp

    def _bounded_solver(self, comm, settings) -> PETSc.SNES:
        """PETSc's ``vinewtonrsls`` for ``K^c c = F^c`` with ``0 <= c <= 1``."""
        snes = PETSc.SNES().create(comm)
        snes.setOptionsPrefix("pfmpm_pf_")
        snes.setType("vinewtonrsls")
        self._residual = self._b.duplicate()

        def residual(snes, x, f):
            self._A.mult(x, f)
            f.axpy(-1.0, self._b)

        snes.setFunction(residual, self._residual)
        snes.setJacobian(lambda snes, x, J, P: None, self._A)  # K^c, assembled by solve()
        self._lower, self._upper = self._b.duplicate(), self._b.duplicate()
        self._lower.set(0.0)
        self._upper.set(1.0)
        snes.setVariableBounds(self._lower, self._upper)
        # Unless the options say otherwise: full steps, as K^c c - F^c is
        # linear; and a vertex is on a bound only when it is exactly there
        # (PETSc's default, within 1e-8, holds the tail of an AT2 profile at
        # c = 1 and frees it one layer of vertices per Newton step).
        options = PETSc.Options("pfmpm_pf_")
        for key, value in (("snes_linesearch_type", "basic"), ("snes_vi_zero_tolerance", 0.0)):
            if not options.hasName(key):
                options[key] = value
        snes.setTolerances(atol=settings.tol * self._b.norm(), rtol=0.0, stol=0.0,
                           max_it=settings.max_iterations)
        # Each Newton step solves for an update from zero: its CG stops on the
        # absolute residual that the SNES test asks for.
        ksp = snes.getKSP()
        ksp.setType(PETSc.KSP.Type.CG)
        ksp.getPC().setType(PETSc.PC.Type.JACOBI)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setTolerances(rtol=1e-50, atol=0.5 * settings.tol * self._b.norm(),
                          max_it=settings.max_iterations)
        snes.setFromOptions()
        return snes

    @property
    def solver(self) -> str:
        """The PETSc method, e.g. ``"cg + jacobi"`` or ``"vinewtonrsls: cg + jacobi"``."""
        inner = f"{self._ksp.getType()} + {self._ksp.getPC().getType()}"
        return f"{self._snes.getType()}: {inner}" if self.bounded else inner

    def solve(self, history: np.ndarray, step: int, t: float) -> None:
        """Solve for ``c`` with the history ``H`` (cells, dim + 1) at the
        facet centroids; raise if the solver fails."""
        self._reaction.x.array[self._point_dof] = _reaction(self._fracture, history)
        self._M.zeroEntries()
        fem_petsc.assemble_matrix(self._M, self._mass_form)
        self._M.assemble()
        self._L.copy(self._A, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._A.axpy(1.0, self._M, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        if self.bounded:
            cold = 0
            if self._plain is not None and self.stats["solves"] == 0:
                # AT2's first solve starts from the unbounded solution: from
                # c = 1, where K^c c - F^c is zero up to round-off of either
                # sign, PETSc would hold a random half of the vertices on the
                # bound and free them one layer per Newton step.
                self._plain.solve(self._b, self.c.vector)
                cold = self._plain.getIterationNumber()
            self._snes.solve(None, self.c.vector)
            its = cold + self._snes.getLinearSolveIterations()
            passes = self._snes.getIterationNumber()
            self.stats["passes"] += passes
            self.stats["last_passes"] = passes
            reason = self._snes.getConvergedReason()
            what = "vinewtonrsls"
        else:
            self._ksp.solve(self._b, self.c.vector)
            its = self._ksp.getIterationNumber()
            reason = self._ksp.getConvergedReason()
            what = "CG"
        self.c.x.scatter_forward()
        self.stats["solves"] += 1
        self.stats["iterations"] += its
        self.stats["last_iterations"] = its
        if reason < 0:
            raise _core.SimulationError(
                f"phase field: {what} stopped without reaching tol = {self._tol:g} after {its}"
                f" iterations (PETSc reason {reason}) at step {step} (t = {t:g})")


class _BelowWarning(logging.Filter):
    """Drops log records below WARNING."""

    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno >= logging.WARNING


def _reaction(fracture, history: np.ndarray) -> np.ndarray:
    """Per history point, the coefficient of ``c q`` in K&T eq. (57) (C++ ``Fracture::reaction``).

    AT2: ``F = 4 l0 (1 - k_f) H / G_c + 1`` (K&T eq. 49); AT1:
    ``16 l0 (1 - k_f) H / (3 G_c)``, no constant term.
    """
    fr = fracture
    if fr.model == "AT1":
        return 16.0 * fr.l0 * (1.0 - fr.k_f) * history / (3.0 * fr.Gc)
    return 4.0 * fr.l0 * (1.0 - fr.k_f) * history / fr.Gc + 1.0


@contextmanager
def _quiet_jit():
    """Keep FFCx 0.5's JIT compiler quiet.

    Its C compiler (through cffi and distutils) sets the root logger, which
    FFCx gives a handler on stderr, to INFO and logs every command it runs:
    those records are dropped and the level is put back.  And when it
    compiles a new form or element, FFCx 0.5 creates the module's C file as a
    lock with ``open(name, "x")`` and never closes it; under ``-W error`` (the
    test suite) that ResourceWarning would fail the first run on a fresh
    cache, so that message is ignored.
    """
    root = logging.getLogger()
    level, drop = root.level, _BelowWarning()
    root.addFilter(drop)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=ResourceWarning,
                                    message=r"unclosed file <_io\.TextIOWrapper name='[^']*libffcx_")
            yield
    finally:
        root.removeFilter(drop)
        root.setLevel(level)


def _entries(dim: int) -> list[tuple[int, int]]:
    """The entries (i, j), i <= j, of a symmetric tensor in the order of its
    columns (:data:`_ENTRY`): xx, yy, xy in 2D; xx, yy, xy, zz, yz, xz in 3D."""
    return sorted(((i, j) for i in range(dim) for j in range(i, dim)), key=lambda e: _ENTRY[dim][e[0]][e[1]])


def _box_of(shape) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The corners ``(min, max)`` of a rectangle, a box or an extruded rectangle."""
    if isinstance(shape, Extrusion):
        return (*shape.shape.min, shape.z0), (*shape.shape.max, shape.z1)
    return tuple(shape.min), tuple(shape.max)


def _supported(scene: Scene) -> tuple[Body, MaterialSpec]:
    """Check that the FEM path can run the scene; return its body and material."""
    if len(scene.bodies) != 1:
        raise SceneError("bodies", f"the FEM path needs exactly one body, not {len(scene.bodies)}")
    body = scene.bodies[0]
    shape = body.shape
    if scene.dim == 2 and not isinstance(shape, Rectangle):
        raise SceneError("bodies[0].shape", "the FEM path needs a rectangle", shape.kind)
    if scene.dim == 3 and not (isinstance(shape, Box)
                               or isinstance(shape, Extrusion) and isinstance(shape.shape, Rectangle)):
        kind = f"extrusion of a {shape.shape.kind}" if isinstance(shape, Extrusion) else shape.kind
        raise SceneError("bodies[0].shape", "the FEM path in 3D needs a box or an extruded rectangle", kind)
    if body.holes:
        raise SceneError("bodies[0].holes", "the FEM path needs a rectangle or box without holes")
    h, origin = scene.grid.h, scene.grid.origin
    lo, hi = _box_of(shape)
    for corner in (lo, hi):
        for x, o in zip(corner, origin):
            n = (x - o) / h
            if abs(n - round(n)) > _WHOLE * max(1.0, abs(n)):
                what = "rectangle whose edges" if scene.dim == 2 else "box whose faces"
                raise SceneError("bodies[0].shape", f"the FEM path needs a {what} lie"
                                 f" on grid lines (multiples of h = {h:g} from the grid origin"
                                 f" {list(origin)})", [list(lo), list(hi)])
    for i, region in enumerate(scene.prescribed):
        if region.particles is not None:
            raise SceneError(f"prescribed[{i}].particles", "the FEM path holds a box, a body or a"
                             " body's face, not particles by index")
    material = scene.material_of(body)
    if not isinstance(material, LinearElasticSpec):
        raise SceneError(f"materials[{scene.materials.index(material)}].model", "the FEM path solves"
                         " small-strain linear elasticity only", material.model)
    anisotropy = material.fracture.anisotropy if material.fracture else None
    if anisotropy is not None and anisotropy.fourth_order:
        index = scene.materials.index(material)
        raise SceneError(f"materials[{index}].fracture.anisotropy", "the FEM path solves the"
                         " second-order functional only (P1 elements have no second derivatives)",
                         anisotropy.symmetry)
    return body, material


def run_command(scene_path: str, out: str, overrides: list[str], quiet: bool = False,
                overwrite: bool = False) -> int:
    """``pfmpm fem SCENE --out DIR [--overwrite]``: run a scene file with the FEM path on
    every rank of ``MPI.COMM_WORLD``; rank 0 prints.  Returns the exit status:
    0 done, 1 failed, 2 a bad scene or output directory, 130 interrupted."""
    comm = MPI.COMM_WORLD
    root = comm.rank == 0
    try:
        check_fresh(out, overwrite)
        scene = Scene.from_toml(scene_path, overrides=overrides)
        sim = FemSimulation(scene, comm)
    except (SceneError, OSError) as err:
        if root:
            print(f"error: {err}", file=sys.stderr)
        return 2
    if root:
        s = sim.summary()
        print(f"{scene.name}: FEM, {s['vertices']} vertices, {s['cells']} cells on {comm.size}"
              f" rank(s), {scene.steps()} steps of dt = {sim.dt:.6g} ({sim.substeps} sub-steps)"
              f" -> {out}")
        for warning in snapshot_warnings(scene):
            print(f"warning: {warning}")
    result = sim.run(out, progress=not quiet, overwrite=overwrite)
    if result.status == "failed":
        if root:
            print(f"error: {result.error}", file=sys.stderr)
            print(f"output so far is in {out}", file=sys.stderr)
        return 1
    if result.status == "interrupted":
        if root:
            print(f"interrupted at step {result.steps}; output so far is in {out}", file=sys.stderr)
        return 130
    if root:
        print(f"done: {result.steps} steps in {result.wall_s:.1f} s; output in {out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m pfmpm.fem SCENE --out DIR``: the same as ``pfmpm fem``."""
    from .cli import main as cli

    return cli(["fem", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
