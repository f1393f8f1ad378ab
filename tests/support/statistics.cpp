#include "support/statistics.hpp"

#include <algorithm>
#include <cstddef>

namespace chasles::testing {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(p * static_cast<double>(values.size())))];
}

}  // namespace chasles::testing
