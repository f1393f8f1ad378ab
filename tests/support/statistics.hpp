// Summaries of what a test measured (times, latencies, spacings).
#pragma once

#include <vector>

namespace chasles::testing {

/// The p-quantile of `values` by rank: the element at index ⌊p·n⌋ of the sorted values (the
/// largest for p = 1, and for any p ≥ (n-1)/n), 0 for none.
double percentile(std::vector<double> values, double p);

}  // namespace chasles::testing
