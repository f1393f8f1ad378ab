// A fit's log, from the samples to the torques it fits (fit_log.hpp): the checks, which refuse a
// log naming the sample, joint or setting at fault; the segments cut at gaps, aligned and filtered;
// the columns where joints move; the split into fitted rows and held-out blocks, and the refusal of a
// log too short or too still, which says how much to log. Apart from the fit (dynamic_fit.cpp)
// because none of it knows the model's parameters: it decides which numbers the fit may use.
#include "core/identification/fit_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace chasles::detail {

std::string number(double x, int digits) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*g", digits, x);
  return text;
}

namespace {

// ---------------------------------------------------------------------------------------------
// Input checks
// ---------------------------------------------------------------------------------------------

void check_options(const DynamicFitOptions& o) {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw IdentificationError("dynamic identification: " + what);
  };
  require(o.cutoff_hz > 0.0 && std::isfinite(o.cutoff_hz), "the cut-off frequency must be a positive number of Hz");
  require(o.filter_order >= 2 && o.filter_order <= 8 && o.filter_order % 2 == 0,
          "the filter order must be 2, 4, 6 or 8");
  require(o.holdout >= 0.0 && o.holdout <= 0.5, "the held-out fraction must be within [0, 0.5]");
  require(o.holdout_blocks >= 2, "the log must be cut into at least 2 blocks for the held-out split");
  require(o.huber > 0.0 && std::isfinite(o.huber), "Huber's threshold must be positive");
  require(o.prior_length > 0.0 && std::isfinite(o.prior_length), "the prior's length scale must be positive");
  require(o.prior_weight > 0.0 && std::isfinite(o.prior_weight), "the prior's weight must be positive");
  require(o.min_range >= 0.0 && std::isfinite(o.min_range), "the least joint range must be ≥ 0");
  require(o.max_condition > 1.0, "the largest condition number must exceed 1");
  require(o.max_iterations >= 1, "the solver needs at least one iteration");
  require(o.threads >= 1, "the solver needs at least one thread");
}

// An arm cannot leave its joints' ranges: a log that does is another arm's, or the URDF is the
// wrong one. (A hair of slack, 0.02 rad or m, for encoders read at the stops; a continuous joint,
// whose model gives ±π, may turn any number of times.)
void check_limits(const RobotModel& model, const Eigen::MatrixXd& q) {
  constexpr double kSlack = 0.02;
  std::string outside;
  for (int i = 0; i < model.dof(); ++i) {
    if (model.joint(i).type == JointType::Continuous) continue;
    const JointLimits& limits = model.joint(i).limits;
    const double low = q.row(i).minCoeff(), high = q.row(i).maxCoeff();
    if (low >= limits.lower - kSlack && high <= limits.upper + kSlack) continue;
    outside += (outside.empty() ? "'" : ", '") + joint_name(model, i) + "' spans [" + number(low) + ", " +
               number(high) + "] against [" + number(limits.lower) + ", " + number(limits.upper) + "]";
  }
  if (!outside.empty()) {
    throw IdentificationError("the log's joints leave the URDF's limits: " + outside + " (rad or m); a log of "
                              "another arm, or the wrong URDF or tip link?");
  }
}

void check_samples(const RobotModel& model, const JointSamples& s) {
  const int n = model.dof();
  const Eigen::Index N = s.t.size();
  if (s.q.rows() != n || s.qd.rows() != n || s.tau.rows() != n) {
    throw IdentificationError("the samples carry " + std::to_string(s.q.rows()) + " joint positions, " +
                              std::to_string(s.qd.rows()) + " velocities and " + std::to_string(s.tau.rows()) +
                              " torques each; the chain '" + model.base_link() + "' -> '" + model.tip_link() +
                              "' has " + std::to_string(n) + " joints (another tip link, or another robot's log?)");
  }
  if (s.q.cols() != N || s.qd.cols() != N || s.tau.cols() != N) {
    throw IdentificationError("the samples hold " + std::to_string(N) + " times but " + std::to_string(s.q.cols()) +
                              " positions, " + std::to_string(s.qd.cols()) + " velocities and " +
                              std::to_string(s.tau.cols()) + " torques: one of each per time");
  }
  const auto at = [&](Eigen::Index k) {
    return "sample " + std::to_string(k) + (std::isfinite(s.t[k]) ? " (t = " + number(s.t[k], 9) + " s)" : "");
  };
  for (Eigen::Index k = 0; k < N; ++k) {
    if (!std::isfinite(s.t[k])) throw IdentificationError(at(k) + ": its time is not finite");
    const struct {
      const Eigen::MatrixXd& values;
      const char* what;
    } fields[] = {{s.q, "position"}, {s.qd, "velocity"}, {s.tau, "torque"}};
    for (const auto& field : fields) {
      for (int i = 0; i < n; ++i) {
        if (!std::isfinite(field.values(i, k))) {
          throw IdentificationError(at(k) + ": joint '" + joint_name(model, i) + "' " + field.what + " is " +
                                    number(field.values(i, k)) + "; every value must be finite");
        }
      }
    }
    if (k > 0 && !(s.t[k] > s.t[k - 1])) {
      throw IdentificationError(at(k) + " is not after sample " + std::to_string(k - 1) + " (t = " +
                                number(s.t[k - 1], 9) + " s): times must increase");
    }
  }
  check_limits(model, s.q);
}

// ---------------------------------------------------------------------------------------------
// Step 1–2: segments, alignment, filtering
// ---------------------------------------------------------------------------------------------

double median_step(const Eigen::VectorXd& t) {
  std::vector<double> steps(static_cast<size_t>(t.size() - 1));
  for (Eigen::Index k = 1; k < t.size(); ++k) steps[static_cast<size_t>(k - 1)] = t[k] - t[k - 1];
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

// Whether a joint's torque at each sample is one the model explains: not while the joint is slow
// (|q̇| < min_speed), nor within `reach` samples of it. At rest or stuck, static friction holds
// whatever torque the rest of the arm leaves, up to its breakaway, and at creeping speeds the
// Stribeck effect lifts friction above Coulomb's f_c; the filter spreads either over its reach.
Eigen::Array<bool, Eigen::Dynamic, 1> joint_moves(const Eigen::VectorXd& qd, double min_speed, Eigen::Index reach) {
  const Eigen::Index L = qd.size();
  Eigen::Array<bool, Eigen::Dynamic, 1> moves = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(L, true);
  Eigen::Index last_slow = -reach - 1;
  for (Eigen::Index k = 0; k < L; ++k) {
    if (std::abs(qd[k]) < min_speed) last_slow = k;
    if (k - last_slow <= reach) moves[k] = false;
  }
  Eigen::Index next_slow = L + reach + 1;
  for (Eigen::Index k = L - 1; k >= 0; --k) {
    if (std::abs(qd[k]) < min_speed) next_slow = k;
    if (next_slow - k <= reach) moves[k] = false;
  }
  return moves;
}

Prepared prepare(const JointSamples& s, const LowPassFilter& filter, double dt, double min_speed) {
  const Eigen::Index N = s.t.size(), n = s.q.rows();
  const Eigen::Index trim = static_cast<Eigen::Index>(std::ceil(2.0 * filter.sample_rate_hz / filter.cutoff_hz));
  const Eigen::Index shortest = 2 * trim + std::max<Eigen::Index>(4, trim / 2);  // 5 / f_c s
  std::vector<std::pair<Eigen::Index, Eigen::Index>> spans;  // [first, end) in the log
  Eigen::Index first = 0;
  int dropped = 0;
  for (Eigen::Index k = 1; k <= N; ++k) {
    if (k < N && s.t[k] - s.t[k - 1] <= 1.5 * dt) continue;
    if (k - first >= shortest) {
      spans.emplace_back(first, k);
    } else {
      dropped += static_cast<int>(k - first);
    }
    first = k;
  }
  Eigen::Index columns = 0;
  for (const auto& [a, b] : spans) columns += b - a - 1 - 2 * trim;
  Prepared p;
  p.dropped = dropped;
  p.t.resize(columns);
  for (Eigen::MatrixXd* m : {&p.q, &p.qd, &p.qdd, &p.tau, &p.tau_filtered, &p.coulomb}) m->resize(n, columns);
  p.moving.resize(n, columns);
  const Eigen::Index reach = static_cast<Eigen::Index>(std::ceil(filter.sample_rate_hz / filter.cutoff_hz));
  Eigen::Index column = 0;
  for (const auto& [a, b] : spans) {
    // The segment's last sample has no successor to centre its torque with.
    const Eigen::Index L = b - a - 1, kept = L - 2 * trim;
    p.segment.push_back(static_cast<int>(column));
    p.t.segment(column, kept) = s.t.segment(a + trim, kept);
    p.q.middleCols(column, kept) = s.q.middleCols(a + trim, kept);
    p.tau.middleCols(column, kept) = s.tau.middleCols(a + trim, kept);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::VectorXd qd = zero_phase_filter(filter, s.qd.row(i).segment(a, L).transpose());
      // τ_k acts over (t_{k−1}, t_k] and τ_{k+1} over (t_k, t_{k+1}]: their mean is what acted about t_k.
      const Eigen::VectorXd centred =
          0.5 * (s.tau.row(i).segment(a, L) + s.tau.row(i).segment(a + 1, L)).transpose();
      // Coulomb's column as τ's Coulomb term is built: its mean over each step (up to the crossing
      // where q̇ changes sign), centred on t_k as τ is, then filtered.
      Eigen::VectorXd sign(L);
      for (Eigen::Index k = 0; k < L; ++k) {
        const double before = k > 0 ? qd[k - 1] : qd[k], after = k + 1 < L ? qd[k + 1] : qd[k];
        sign[k] = 0.5 * (mean_sign(before, qd[k]) + mean_sign(qd[k], after));
      }
      p.qd.row(i).segment(column, kept) = qd.segment(trim, kept).transpose();
      p.moving.row(i).segment(column, kept) = joint_moves(qd, min_speed, reach).segment(trim, kept).transpose();
      p.qdd.row(i).segment(column, kept) = central_difference(qd, dt).segment(trim, kept).transpose();
      p.tau_filtered.row(i).segment(column, kept) =
          at_the_instant(zero_phase_filter(filter, centred)).segment(trim, kept).transpose();
      p.coulomb.row(i).segment(column, kept) =
          at_the_instant(zero_phase_filter(filter, sign)).segment(trim, kept).transpose();
    }
    column += kept;
  }
  p.segment.push_back(static_cast<int>(column));
  return p;
}

// The log must give kTorquesPerParameter torques per fitted parameter, and something to judge the
// fit on. Three, as before, let a 3 s log of a Panda with stiction through (62 base parameters from
// 420 torques) whose report claimed 0.05-0.1 N·m where a different motion showed 0.39: the fit
// follows that short motion and nothing else. Fifteen is most of one 10 s period of the default
// excitation.
constexpr int kTorquesPerParameter = 15;

// The joints, in order, that move in less than `below` of the motion, each with its share: a
// joint stuck or still that long leaves too few of its torques to fit.
std::string stuck_joints(const RobotModel& model, const Eigen::VectorXd& share, double below) {
  std::string text;
  for (int i = 0; i < share.size(); ++i) {
    if (share[i] >= below) continue;
    text += (text.empty() ? "'" : ", '") + joint_name(model, i) + "' (moving " + number(100.0 * share[i], 2) + " %)";
  }
  return text;
}

}  // namespace

double mean_sign(double before, double after) {
  const double s0 = (before > 0.0) - (before < 0.0), s1 = (after > 0.0) - (after < 0.0);
  if (s0 * s1 >= 0.0) return 0.5 * (s0 + s1);
  const double u = std::abs(before) / (std::abs(before) + std::abs(after));
  return s0 * u + s1 * (1.0 - u);
}

// A centred torque is the mean over the two steps about t_k, τ(t_k) + dt²/6 τ̈(t_k) + O(dt⁴); once
// filtered, τ̈ dt² is its second difference, and taking a sixth of it off leaves the instant's
// torque (at 500 Hz the difference is 1e-3 of a fast arm's torque, a tenth of the noise's standard
// error on a load's mass). The ends, where there is no second difference, are trimmed anyway.
Eigen::VectorXd at_the_instant(Eigen::VectorXd x) {
  const Eigen::VectorXd centred = x;
  for (Eigen::Index k = 1; k + 1 < x.size(); ++k) x[k] -= (centred[k + 1] - 2.0 * centred[k] + centred[k - 1]) / 6.0;
  return x;
}

LogSplit split_log(const RobotModel& model, const JointSamples& samples, const DynamicFitOptions& options,
                   LogUse& use) {
  check_options(options);
  check_samples(model, samples);
  const int n = model.dof();
  const Eigen::Index N = samples.t.size();
  if (N < 4) {
    throw IdentificationError("the log holds " + std::to_string(N) +
                              " samples; a fit needs seconds of an arm moving, thousands of samples");
  }
  use.samples = static_cast<int>(N);
  use.duration_s = samples.t[N - 1] - samples.t[0];
  const double dt = median_step(samples.t);
  use.sample_rate_hz = 1.0 / dt;
  if (!(options.cutoff_hz < 0.5 * use.sample_rate_hz)) {
    throw IdentificationError("the cut-off " + number(options.cutoff_hz) +
                              " Hz is not below the log's Nyquist frequency " + number(0.5 * use.sample_rate_hz) +
                              " Hz (a sample every " + number(dt * 1e3) + " ms): choose a lower cut-off");
  }

  // Every joint must move, or the torques say nothing of what it carries.
  std::string still;
  for (int i = 0; i < n; ++i) {
    const double range = samples.q.row(i).maxCoeff() - samples.q.row(i).minCoeff();
    if (range < options.min_range) {
      still += (still.empty() ? "" : ", ") + ("'" + joint_name(model, i) + "' (range " + number(range) + ")");
    }
  }
  if (!still.empty()) {
    throw IdentificationError("the log does not excite the arm: joints that barely move: " + still + ", under " +
                              number(options.min_range) +
                              " rad or m; run an excitation trajectory that moves every joint");
  }

  LogSplit split;
  split.filter = butterworth_low_pass(options.filter_order, options.cutoff_hz, use.sample_rate_hz);
  split.data = prepare(samples, split.filter, dt, options.min_speed);
  const Prepared& data = split.data;
  use.segments = static_cast<int>(data.segment.size()) - 1;
  use.dropped_samples = data.dropped;
  // (A hair over the quotient, so that 500 Hz over 25 Hz is 20 even when the times' rounding
  // makes the rate 499.99999 Hz.)
  use.decimation = std::max(1, static_cast<int>(std::floor(use.sample_rate_hz / (2.5 * options.cutoff_hz) + 1e-6)));

  // The motion: columns where some joint moves. Rest says nothing and is left out whole; the
  // blocks are cut in the motion alone, so that rest does not fill the held-out share.
  const Eigen::Index columns = data.t.size();
  std::vector<int> rank(static_cast<size_t>(columns), -1);
  int motion = 0;
  Eigen::VectorXd moving_count = Eigen::VectorXd::Zero(n);
  for (Eigen::Index c = 0; c < columns; ++c) {
    if (!data.moving.col(c).any()) continue;
    rank[static_cast<size_t>(c)] = motion++;
    for (int i = 0; i < n; ++i) moving_count[i] += data.moving(i, c) ? 1.0 : 0.0;
  }
  use.motion_seconds = motion * dt;
  use.rest_seconds = static_cast<double>(columns - motion) * dt;
  use.moving_share = moving_count / std::max(1.0, static_cast<double>(motion));
  if (columns > 0 && motion == 0) {  // (a log too short to filter has no columns: check_length says so)
    throw IdentificationError("the log holds no motion: no joint moves at " + number(options.min_speed) +
                              " rad/s or m/s or faster (over " + number(use.duration_s) +
                              " s); log the arm while it runs an excitation trajectory");
  }
  constexpr double kLeastShare = 0.2;
  if (const std::string stuck = stuck_joints(model, use.moving_share, kLeastShare); motion > 0 && !stuck.empty()) {
    throw IdentificationError(
        "joints stuck or still for most of the motion: " + stuck + " of its " + number(use.motion_seconds) +
        " s at " + number(options.min_speed) + " rad/s or m/s or faster; while a joint sticks, static friction holds "
        "a torque no model of the log can tell, so those torques are left out and too few remain (every joint must "
        "move in " + number(100.0 * kLeastShare) + " % of it): stiffen the controller's joint gains or run the "
        "excitation faster (a shorter --period) so that the joints break away");
  }

  // Held-out blocks: the last H of B blocks of the motion, so that the judgement is made on motion
  // the fit never saw nor neighbours.
  const int B = options.holdout_blocks;
  const int H = static_cast<int>(std::lround(options.holdout * B));
  for (int b = B - H; b < B; ++b) use.holdout_blocks.push_back(b);
  for (size_t s = 0; s + 1 < data.segment.size(); ++s) {
    for (int c = data.segment[s]; c < data.segment[s + 1]; ++c) {
      const int r = rank[static_cast<size_t>(c)];
      if (r < 0) continue;
      const int block = std::min(B - 1, static_cast<int>(static_cast<int64_t>(r) * B / motion));
      if (block >= B - H) {
        if (c > data.segment[s]) split.holdout.push_back(c);  // its predecessor is needed
      } else if ((c - data.segment[s]) % use.decimation == 0) {
        for (int i = 0; i < n; ++i) {
          if (!data.moving(i, c)) continue;
          split.row_sample.push_back(static_cast<int>(split.fit.size()));
          split.row_joint.push_back(i);
        }
        split.fit.push_back(c);
      }
    }
  }
  use.fit_samples = static_cast<int>(split.fit.size());
  use.fit_torques = static_cast<int>(split.row_joint.size());
  use.holdout_samples = static_cast<int>(split.holdout.size());
  use.holdout_seconds = use.holdout_samples * dt;
  return split;
}

// Refuses a log that gives too few torques for `parameters` (kTorquesPerParameter), or nothing to
// judge the fit on, saying how long a log would do.
void check_length(const LogUse& use, int joints, int parameters, const std::string& what,
                  const DynamicFitOptions& options) {
  const int rows = use.fit_torques;
  if (rows >= kTorquesPerParameter * parameters && (use.holdout_blocks.empty() || use.holdout_samples > 0)) return;
  const double dt = 1.0 / use.sample_rate_hz;
  const double used = use.fit_samples > 0 ? static_cast<double>(rows) / (use.fit_samples * joints) : 1.0;
  const double needed =
      std::ceil(kTorquesPerParameter * parameters / (joints * std::max(used, 0.5))) * use.decimation * dt /
          (1.0 - options.holdout) +
      4.0 / options.cutoff_hz;
  const std::string left_out =
      use.rest_seconds > 0.0 || used < 1.0
          ? "; left out: " + number(use.rest_seconds) + " s of rest and, in the motion, " +
                number(100.0 * (1.0 - used), 2) + " % of the joints' torques where they were slow or stuck"
          : "";
  throw IdentificationError("the log is too short: " + number(use.duration_s) + " s at " + number(use.sample_rate_hz) +
                            " Hz hold " + number(use.motion_seconds) + " s of motion, which give " +
                            std::to_string(use.fit_samples) + " samples to fit (" + std::to_string(rows) +
                            " torques) for " + std::to_string(parameters) + " " + what + ", and " +
                            std::to_string(use.holdout_samples) + " held out" + left_out + "; the fit needs " +
                            std::to_string(kTorquesPerParameter) + " torques per parameter: log at least " +
                            number(std::max(needed, 4.0 * options.holdout_blocks * dt)) + " s of motion" +
                            (use.dropped_samples > 0 ? ", in stretches without gaps of at least " +
                                                           number(5.0 / options.cutoff_hz) + " s (" +
                                                           std::to_string(use.dropped_samples) +
                                                           " samples lay in shorter ones, too short to filter)"
                                                     : ""));
}

}  // namespace chasles::detail
