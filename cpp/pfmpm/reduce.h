/// @file reduce.h
/// @brief Sums whose rounding does not depend on the number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace pfmpm
{

/// @brief Sum K quantities over i in [0, n) in fixed blocks.
///
/// Each block of `block` consecutive indices is summed in index order and the
/// block sums are added in block order, so the result has the same bits for
/// any thread count and schedule.
/// @param n Number of terms.
/// @param f Callable f(i, acc) adding term i into acc (std::array<double, K>&).
template <std::size_t K, class F>
std::array<double, K> deterministic_sum(std::size_t n, F&& f)
{
  constexpr std::ptrdiff_t block = 4096;
  const std::ptrdiff_t nblocks = (static_cast<std::ptrdiff_t>(n) + block - 1) / block;
  std::vector<std::array<double, K>> partial(nblocks);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t b = 0; b < nblocks; ++b)
  {
    std::array<double, K> acc{};
    const std::ptrdiff_t end = std::min<std::ptrdiff_t>((b + 1) * block, n);
    for (std::ptrdiff_t i = b * block; i < end; ++i)
      f(static_cast<std::size_t>(i), acc);
    partial[b] = acc;
  }
  std::array<double, K> total{};
  for (const auto& acc : partial)
    for (std::size_t k = 0; k < K; ++k)
      total[k] += acc[k];
  return total;
}

} // namespace pfmpm
