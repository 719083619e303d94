/// @file particles.h
/// @brief Material point storage, struct of arrays.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// @brief Material points as contiguous arrays, row-major (N x k) where a
/// quantity has k components.
///
/// Shapes: x, v, fext (N x 2); strain (N x 3: xx, yy, xy, tensor components);
/// stress (N x 4: xx, yy, xy, zz); every other array (N). The phase field c
/// (1 = intact, 0 = broken, the paper's convention), history H and material
/// orientation phi are stored for the fracture modules that use them.
struct Particles
{
  /// @brief Create n particles at rest with zero strain and stress, c = 1.
  explicit Particles(std::size_t n);

  std::size_t size() const { return mass.size(); }

  std::vector<double> x;        ///< position
  std::vector<double> v;        ///< velocity
  std::vector<double> mass;     ///< mass M_p
  std::vector<double> volume;   ///< current volume V_p
  std::vector<double> strain;   ///< small strain (eq. 78)
  std::vector<double> stress;   ///< Cauchy stress
  std::vector<double> fext;     ///< external force: body force and traction (eq. 42)
  std::vector<std::int32_t> body;     ///< body (discrete field) index
  std::vector<std::int32_t> material; ///< material index
  std::vector<double> c;        ///< phase field at the point
  std::vector<double> history;  ///< history field H (eq. 20)
  std::vector<double> phi;      ///< material orientation angle
};

} // namespace pfmpm
