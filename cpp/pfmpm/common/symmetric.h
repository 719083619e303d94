/// @file symmetric.h
/// @brief The layout of a symmetric tensor per particle (the Cauchy stress),
/// one for 2D and 3D: xx, yy, xy, zz, then in 3D yz, xz. A 2D tensor is the
/// first four, zz its out-of-plane entry (plane strain or plane stress).
#pragma once

namespace pfmpm
{

/// Stored components of a symmetric tensor in `dim` directions: 4 in 2D, 6 in 3D.
constexpr int symmetric_size(int dim) { return dim == 2 ? 4 : 6; }

/// The entry of component (i, j) of a symmetric tensor in that layout.
constexpr int symmetric_entry(int i, int j)
{
  if (i > j)
    return symmetric_entry(j, i);
  // (0,0) (1,1) (0,1) (2,2) (1,2) (0,2)
  return i == j ? (i == 2 ? 3 : i) : j == 1 ? 2 : i == 1 ? 4 : 5;
}

static_assert(symmetric_entry(0, 0) == 0 && symmetric_entry(1, 1) == 1 && symmetric_entry(1, 0) == 2
              && symmetric_entry(2, 2) == 3 && symmetric_entry(2, 1) == 4 && symmetric_entry(0, 2) == 5);

} // namespace pfmpm
