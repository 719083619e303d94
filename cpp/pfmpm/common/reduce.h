/// @file reduce.h
/// @brief Sums whose rounding does not depend on the number of threads.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfmpm
{

/// Terms per block of deterministic_sum.
inline constexpr std::size_t deterministic_block = 4096;

/// @brief Sum K quantities over the blocks of [0, n), `deterministic_block`
/// indices each: f(begin, end, acc) adds the terms of [begin, end) into acc,
/// which starts at zero for every block, and the block sums are added in
/// block order, so the result has the same bits for any thread count and
/// schedule.
template <std::size_t K, class F>
std::array<double, K> deterministic_block_sum(std::size_t n, F&& f)
{
  const auto block = static_cast<std::ptrdiff_t>(deterministic_block);
  const std::ptrdiff_t nblocks = (static_cast<std::ptrdiff_t>(n) + block - 1) / block;
  std::vector<std::array<double, K>> partial(nblocks);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t b = 0; b < nblocks; ++b)
  {
    std::array<double, K> acc{};
    const std::ptrdiff_t end = std::min<std::ptrdiff_t>((b + 1) * block, n);
    f(static_cast<std::size_t>(b * block), static_cast<std::size_t>(end), acc);
    partial[b] = acc;
  }
  std::array<double, K> total{};
  for (const auto& acc : partial)
    for (std::size_t k = 0; k < K; ++k)
      total[k] += acc[k];
  return total;
}

/// @brief Sum K quantities over i in [0, n) in fixed blocks, each in index
/// order (deterministic_block_sum).
/// @param n Number of terms.
/// @param f Callable f(i, acc) adding term i into acc (std::array<double, K>&).
template <std::size_t K, class F>
std::array<double, K> deterministic_sum(std::size_t n, F&& f)
{
  return deterministic_block_sum<K>(n,
                                    [&](std::size_t begin, std::size_t end, std::array<double, K>& acc)
                                    {
                                      for (std::size_t i = begin; i < end; ++i)
                                        f(i, acc);
                                    });
}

/// @brief Node columns along x per slab of the grid's sums (slab_sum): a
/// process that owns whole slabs, as a rank owning whole tiles of cells
/// (tile_cells) along x does, sums its nodes as one process would.
inline constexpr int slab_nodes = 8;

/// Number of slabs of a grid with `nodes_x` nodes along x.
inline std::int64_t num_slabs(std::int64_t nodes_x) { return (nodes_x + slab_nodes - 1) / slab_nodes; }

/// @brief Sum K quantities over active nodes by slab: slab s holds the nodes
/// whose x index lies in [s slab_nodes, (s + 1) slab_nodes). f(a, acc) adds
/// the terms of active node a into acc, which starts at zero for every slab,
/// the slab's nodes in index order.
/// @param nodes Node index (key) of each active node, ascending.
/// @param stride Nodes per x index (nodes_y in 2D, nodes_y nodes_z in 3D).
/// @param slabs Number of slabs (num_slabs).
/// @return Per slab, its sums: the same bits for any thread count and
///         whichever process holds the slab.
template <std::size_t K, class F>
std::vector<std::array<double, K>> slab_sum(const std::vector<std::int32_t>& nodes, std::int64_t stride,
                                            std::int64_t slabs, F&& f)
{
  std::vector<std::array<double, K>> sums(slabs);
#pragma omp parallel for schedule(dynamic)
  for (std::int64_t s = 0; s < slabs; ++s)
  {
    const auto first = std::lower_bound(nodes.begin(), nodes.end(), s * slab_nodes * stride);
    const auto last = std::lower_bound(first, nodes.end(), (s + 1) * slab_nodes * stride);
    std::array<double, K> acc{};
    for (auto a = first; a != last; ++a)
      f(static_cast<std::size_t>(a - nodes.begin()), acc);
    sums[s] = acc;
  }
  return sums;
}

} // namespace pfmpm
