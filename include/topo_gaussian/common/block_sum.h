// Reproducible parallel sums: S = Σ_b (Σ_{i ∈ block b} term(i)), the particles cut into fixed blocks of
// kSumBlock, each block summed in index order (in parallel), the blocks' sums added in block order.
// The same bits on any number of threads and in every run. An OpenMP reduction, or one partial sum per
// thread, adds in an order that depends on the thread count or on which thread finishes first; the
// mass moments and the quadric's gradient then differed in their last bits between runs and machines,
// and an inference whose line search is sensitive to them (the tumbler's) ended at loss 4e-16 in one
// run and 2.6e-4 in the next on a 16-core machine.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace topo_gaussian {

constexpr std::ptrdiff_t kSumBlock = 2048;

/// Σ_{i < n} add(&acc, i) over fixed blocks. Acc: a value-initialisable accumulator with +=
/// (double, std::array via a wrapper, Eigen fixed vectors); add(Acc* acc, i) adds term i into *acc.
/// Parallel (OpenMP) when n > kSumBlock.
template <class Acc, class AddTerm>
Acc blockSum(std::ptrdiff_t n, const Acc& zero, const AddTerm& add) {
  const std::ptrdiff_t blocks = (n + kSumBlock - 1) / kSumBlock;
  std::vector<Acc> part(static_cast<std::size_t>(std::max<std::ptrdiff_t>(blocks, 0)), zero);
#pragma omp parallel for schedule(static) if (blocks > 1)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    Acc acc = zero;
    for (std::ptrdiff_t i = b * kSumBlock, e = std::min(n, i + kSumBlock); i < e; ++i) add(&acc, i);
    part[static_cast<std::size_t>(b)] = acc;
  }
  Acc total = zero;
  for (const Acc& p : part) total += p;
  return total;
}

}  // namespace topo_gaussian
