#include "controller/statistics.hpp"

#include <algorithm>
#include <cmath>

namespace chasles::controller {
namespace {

constexpr int kFineBins = 2000;     // [0, 2000) µs by 1 µs
constexpr int kCoarseBins = 980;    // [2, 100) ms by 100 µs
constexpr int kBins = kFineBins + kCoarseBins + 1;

int bin_of(double us) {
  if (!(us > 0.0)) return 0;  // negative and NaN land in the first bin
  if (us < kFineBins) return static_cast<int>(us);
  const double coarse = (us - kFineBins) / 100.0;
  return coarse < kCoarseBins ? kFineBins + static_cast<int>(coarse) : kBins - 1;
}

double upper_edge(int bin) {
  if (bin < kFineBins) return bin + 1.0;
  return kFineBins + 100.0 * (bin - kFineBins + 1);
}

}  // namespace

Histogram::Histogram() : bins_(kBins, 0) {}

void Histogram::record(double us) {
  ++bins_[static_cast<size_t>(bin_of(us))];
  max_ = count_ == 0 ? us : std::max(max_, us);
  ++count_;
}

void Histogram::merge(const Histogram& other) {
  for (size_t i = 0; i < bins_.size(); ++i) bins_[i] += other.bins_[i];
  if (other.count_) max_ = count_ ? std::max(max_, other.max_) : other.max_;
  count_ += other.count_;
}

void Histogram::reset() {
  std::fill(bins_.begin(), bins_.end(), 0);
  count_ = 0;
  max_ = 0.0;
}

double Histogram::percentile(double p) const {
  if (count_ == 0) return 0.0;
  const auto rank = static_cast<int64_t>(std::ceil(p * static_cast<double>(count_)));
  int64_t seen = 0;
  for (size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= std::max<int64_t>(rank, 1)) return std::min(upper_edge(static_cast<int>(i)), max_);
  }
  return max_;
}

Percentiles percentiles(const Histogram& h) { return {h.percentile(0.5), h.percentile(0.99), h.max()}; }

}  // namespace chasles::controller
