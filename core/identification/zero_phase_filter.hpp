// The zero-phase low-pass filter identification reads an arm's log through. Joint accelerations
// are not measured: q̈ is the derivative of the logged q̇, which differentiation makes noisy, so q̇
// is low-passed first; and τ must pass through the same filter, or the fit would compare a torque
// with the motion of a moment before (a causal filter delays) or of another bandwidth. A
// Butterworth filter run forwards and then backwards (MATLAB's and SciPy's filtfilt) has zero phase
// at every frequency and the square of the Butterworth magnitude, 1 / (1 + (f / f_c)^2N): flat
// below the cut-off, −6 dB at it.
//
// The filter is a cascade of second-order sections (biquads), the bilinear transform of the analog
// Butterworth prototype with the cut-off pre-warped, so that the digital filter's −3 dB point is
// exactly f_c (Oppenheim and Schafer §7.1; the biquads are those of R. Bristow-Johnson's "Audio EQ
// Cookbook", low-pass, with each section's Q = 1 / (2 cos((2k + 1) π / 2N))).
#pragma once

#include <vector>

#include "core/error.hpp"
#include "core/lie/types.hpp"

namespace chasles {

/// y[k] = b0 x[k] + b1 x[k−1] + b2 x[k−2] − a1 y[k−1] − a2 y[k−2].
struct Biquad {
  double b0 = 1.0, b1 = 0.0, b2 = 0.0, a1 = 0.0, a2 = 0.0;
};

struct LowPassFilter {
  int order = 0;
  double cutoff_hz = 0.0;
  double sample_rate_hz = 0.0;
  std::vector<Biquad> sections;  ///< order / 2 of them, each with unit gain at 0 Hz
};

/// The digital Butterworth low-pass of an even `order` (2 to 8) with its −3 dB point at
/// `cutoff_hz`, for samples taken at `sample_rate_hz`. Throws ArgumentError for an odd or
/// out-of-range order, or a cut-off that is not positive or not below the Nyquist frequency.
LowPassFilter butterworth_low_pass(int order, double cutoff_hz, double sample_rate_hz);

/// How many samples zero_phase_filter reflects beyond each end: 15 time constants of the
/// filter's slowest poles, 1 / (2π f_c sin(π / 2N)), by when what the start of a pass got wrong has
/// fallen by e⁻¹⁵ = 3e-7 (624 samples for N = 4 at f_c = 10 Hz and 1 kHz); at most length − 1.
int zero_phase_padding(const LowPassFilter& filter, Eigen::Index length);

/// filtfilt: x filtered forwards, then the result backwards, so that the phase cancels. The ends
/// are handled as SciPy's filtfilt does (padtype "odd"): x is extended by its point reflection
/// about each end, 2 x[0] − x[k], which continues its value and slope, and each pass starts in the
/// filter's steady state for the first value it meets, so no step is filtered in at the edges.
/// Throws ArgumentError for fewer than 2 samples.
Eigen::VectorXd zero_phase_filter(const LowPassFilter& filter, const Eigen::Ref<const Eigen::VectorXd>& x);

/// dx/dt of uniformly sampled x by central differences: the five-point (x[k−2] − 8 x[k−1] +
/// 8 x[k+1] − x[k+2]) / 12 dt, fourth-order accurate — the three-point one's error, dt²/6 x⃛, would
/// be 2e-4 rad/s² on an arm's q̈ at 500 Hz, torques of a standard error on a fitted load — and
/// the three-point and one-sided second-order differences in the two samples at either end,
/// which a fit leaves out. Needs 3 samples.
Eigen::VectorXd central_difference(const Eigen::Ref<const Eigen::VectorXd>& x, double dt);

}  // namespace chasles
