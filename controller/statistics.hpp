// Percentiles of timing samples without keeping the samples: a fixed histogram, allocated once.
#pragma once

#include <cstdint>
#include <vector>

namespace chasles::controller {

/// Microsecond samples: 1 µs bins up to 2 ms (where a 1 kHz loop's figures live), 100 µs bins up
/// to 100 ms, one overflow bin; the maximum is kept exactly. A percentile is the upper edge of
/// the bin it falls in, so it is exact to the bin width and never optimistic.
class Histogram {
 public:
  Histogram();
  void record(double us);
  void merge(const Histogram& other);
  void reset();

  int64_t count() const { return count_; }
  double max() const { return count_ ? max_ : 0.0; }
  /// p in [0, 1]; 0 when empty.
  double percentile(double p) const;

 private:
  std::vector<int64_t> bins_;
  int64_t count_ = 0;
  double max_ = 0.0;
};

/// The three figures every report gives.
struct Percentiles {
  double p50 = 0.0, p99 = 0.0, max = 0.0;
};
Percentiles percentiles(const Histogram& h);

}  // namespace chasles::controller
