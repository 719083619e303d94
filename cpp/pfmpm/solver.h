/// @file solver.h
/// @brief Explicit MPM time stepping (Kakouris & Triantafyllou 2019, Algorithm 1).
#pragma once

#include "grid.h"
#include "material.h"
#include "particles.h"

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace pfmpm
{

/// @brief A run cannot continue: a particle left the grid or a value became
/// NaN or infinite. The message names the quantity, particle, step and time.
class SimulationError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Global quantities of the particle state.
struct Energies
{
  double kinetic = 0.0;        ///< sum of M_p |v_p|^2 / 2
  double elastic = 0.0;        ///< sum of V_p psi(eps_p)
  double external_work = 0.0;  ///< work of the external forces since t = 0
  std::array<double, 2> momentum{}; ///< sum of M_p v_p
  double mass = 0.0;           ///< sum of M_p
};

/// @brief Explicit update-stress-last MPM in the momentum formulation.
///
/// One step: sort particles by cell, activate the grid nodes they touch,
/// map mass, momentum and forces to the grid (P2G), integrate nodal momentum
/// with wall conditions, map velocity and acceleration back (G2P), then
/// update strain and stress. Every sum over particles is taken in an order
/// fixed by the particle positions alone, so results do not depend on the
/// thread count.
class Solver
{
public:
  /// @param grid Background grid (kept by reference; must outlive the solver).
  /// @param particles Particle state (kept by reference; must outlive the solver).
  /// @param materials Materials indexed by Particles::material.
  /// @param dt Time step (> 0); the caller checks it against the CFL limit.
  Solver(Grid& grid, Particles& particles, std::vector<LinearElastic> materials, double dt);

  /// @brief Take `steps` explicit steps.
  /// @throws SimulationError when a particle leaves the grid or turns non-finite.
  void advance(std::int64_t steps);

  double dt() const { return _dt; }
  double time() const { return _time; }
  std::int64_t step_count() const { return _step; }

  /// @brief Energies and momentum of the current particle state.
  Energies energies() const;

  /// @brief Map the current particle state to the grid (P2G only) and return,
  /// per active node, (node index, mass, momentum x, momentum y). For checks.
  std::vector<std::array<double, 4>> nodal_mass_momentum();

private:
  template <int P>
  void step();
  /// Sort, activate nodes and P2G: the grid state at the start of a step.
  template <int P>
  void map_to_grid();
  void sort_particles();
  template <int P>
  void particle_to_grid();
  template <int P, bool External>
  void particle_to_grid();
  void update_grid();
  template <int P>
  void grid_to_particle();
  std::string where(std::size_t particle) const;
  bool has_external_force() const;

  /// P2G accumulators of one active node.
  struct NodeSums
  {
    double m, px, py;   // mass (eq. 46) and momentum (eq. 61)
    double fx, fy;      // net force F^ext - F^int (eqs. 42, 62)
    double ex, ey;      // external force alone, for the work it does
  };
  /// Updated velocity and acceleration of one active node (eqs. 63-64).
  struct NodeKinematics
  {
    double vx, vy, ax, ay;
  };

  Grid& _grid;
  Particles& _particles;
  std::vector<LinearElastic> _materials;
  double _dt;
  double _time = 0.0;
  std::int64_t _step = 0;
  double _external_work = 0.0;
  double _mass_tol;
  bool _external = false; // some particle carries an external force

  std::vector<std::int32_t> _cell;        // per particle: cell key
  std::vector<std::int32_t> _order;       // particles sorted by cell, stable
  std::vector<std::int64_t> _cell_start;  // offsets into _order, per cell
  std::vector<std::int64_t> _histogram;   // threads x cells, sort scratch
  std::vector<NodeSums> _sums;            // per active node
  std::vector<NodeKinematics> _kinematics; // per active node
};

} // namespace pfmpm
