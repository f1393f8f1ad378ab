#include "core/identification/zero_phase_filter.hpp"

#include <cmath>
#include <string>

namespace chasles {

namespace {

// One pass of the cascade over x in place, each section in transposed direct form II and started
// in its steady state for the constant input x[0]: every section passes 0 Hz with unit gain, so
// each sees x[0] at its input and output, and its two states follow from the difference equation.
void filter_in_place(const LowPassFilter& filter, Eigen::VectorXd& x) {
  const double u = x[0];
  for (const Biquad& s : filter.sections) {
    double z2 = (s.b2 - s.a2) * u;
    double z1 = (1.0 - s.b0) * u;
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double in = x[k];
      const double out = s.b0 * in + z1;
      z1 = s.b1 * in - s.a1 * out + z2;
      z2 = s.b2 * in - s.a2 * out;
      x[k] = out;
    }
  }
}

}  // namespace

LowPassFilter butterworth_low_pass(int order, double cutoff_hz, double sample_rate_hz) {
  if (order < 2 || order > 8 || order % 2 != 0) {
    throw ArgumentError("Butterworth low-pass: order " + std::to_string(order) + " is not one of 2, 4, 6, 8");
  }
  if (!(sample_rate_hz > 0.0) || !std::isfinite(sample_rate_hz)) {
    throw ArgumentError("Butterworth low-pass: sample rate " + std::to_string(sample_rate_hz) + " Hz is not positive");
  }
  if (!(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_rate_hz)) {
    throw ArgumentError("Butterworth low-pass: cut-off " + std::to_string(cutoff_hz) +
                        " Hz must be positive and below the Nyquist frequency, " +
                        std::to_string(0.5 * sample_rate_hz) + " Hz for samples at " + std::to_string(sample_rate_hz) +
                        " Hz");
  }
  LowPassFilter filter{order, cutoff_hz, sample_rate_hz, {}};
  // Pre-warped: the bilinear transform maps the analog frequency 2 f_s tan(π f / f_s) to f.
  const double K = std::tan(kPi * cutoff_hz / sample_rate_hz);
  for (int k = 0; k < order / 2; ++k) {
    // The analog prototype's k-th conjugate pole pair, at angle (2k + 1) π / 2N from the negative
    // real axis, as a second-order section of quality factor Q.
    const double Q = 1.0 / (2.0 * std::cos((2 * k + 1) * kPi / (2.0 * order)));
    const double norm = 1.0 / (1.0 + K / Q + K * K);
    Biquad s;
    s.b0 = K * K * norm;
    s.b1 = 2.0 * s.b0;
    s.b2 = s.b0;
    s.a1 = 2.0 * (K * K - 1.0) * norm;
    s.a2 = (1.0 - K / Q + K * K) * norm;
    filter.sections.push_back(s);
  }
  return filter;
}

int zero_phase_padding(const LowPassFilter& filter, Eigen::Index length) {
  // The slowest poles of a Butterworth filter are the pair nearest the imaginary axis, decaying
  // at ω_c sin(π / 2N).
  const double time_constant = 1.0 / (2.0 * kPi * filter.cutoff_hz * std::sin(kPi / (2.0 * filter.order)));
  const double samples = std::ceil(15.0 * time_constant * filter.sample_rate_hz);
  return static_cast<int>(std::min<double>(samples, static_cast<double>(length - 1)));
}

Eigen::VectorXd zero_phase_filter(const LowPassFilter& filter, const Eigen::Ref<const Eigen::VectorXd>& x) {
  const Eigen::Index n = x.size();
  if (n < 2) throw ArgumentError("zero-phase filter: " + std::to_string(n) + " samples; it needs at least 2");
  const Eigen::Index pad = zero_phase_padding(filter, n);
  Eigen::VectorXd extended(n + 2 * pad);
  for (Eigen::Index k = 0; k < pad; ++k) {
    extended[k] = 2.0 * x[0] - x[pad - k];
    extended[pad + n + k] = 2.0 * x[n - 1] - x[n - 2 - k];
  }
  extended.segment(pad, n) = x;
  filter_in_place(filter, extended);
  extended.reverseInPlace();
  filter_in_place(filter, extended);
  extended.reverseInPlace();
  return extended.segment(pad, n);
}

Eigen::VectorXd central_difference(const Eigen::Ref<const Eigen::VectorXd>& x, double dt) {
  const Eigen::Index n = x.size();
  if (n < 3) throw ArgumentError("central difference: " + std::to_string(n) + " samples; it needs at least 3");
  Eigen::VectorXd dx(n);
  for (Eigen::Index k = 2; k + 2 < n; ++k) {
    dx[k] = (x[k - 2] - 8.0 * x[k - 1] + 8.0 * x[k + 1] - x[k + 2]) / (12.0 * dt);
  }
  dx[1] = (x[2] - x[0]) / (2.0 * dt);
  dx[n - 2] = (x[n - 1] - x[n - 3]) / (2.0 * dt);
  dx[0] = (-3.0 * x[0] + 4.0 * x[1] - x[2]) / (2.0 * dt);
  dx[n - 1] = (3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) / (2.0 * dt);
  return dx;
}

}  // namespace chasles
