// The controller as a node on a bus, in steps: everything the daemon's threads do, one call per
// turn of each loop, on a Clock. The Daemon runs the steps on their threads with the system
// clock and UDP multicast; the in-process tests run them in one thread on a SimulatedClock and a
// memq:// bus beside a simulated plant, tick by tick.
//
//   tick()    the real-time loop's body: latest state → Controller::tick → command sent from a
//             preallocated buffer → a timing record queued. Allocates nothing. State-driven,
//             it runs as soon as a state has been handled (state_waiting()), and on the clock
//             only as the watchdog when states stop.
//   plan()    the IK worker's: one Cartesian goal planned into a joint path with Ceres, or a
//             payload built into the model the loop swaps in at its next tick
//   report()  the status thread's: timing records into histograms, changes on stderr,
//             controller_status_t at status_hz (at once on a change of mode)
//
// The bus's handler (Bus::handle on the receiving bus: the real-time loop's own thread when
// state-driven) feeds the receivers, which hand over through lock-free mailboxes and rings: no
// step waits for another. The loop rings the workers' doorbells when it hands them work.
#pragma once

#include <chasles/contact_estimate_t.hpp>
#include <chasles/controller_status_t.hpp>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "controller/controller.hpp"
#include "controller/options.hpp"
#include "controller/statistics.hpp"
#include "controller/transport/inbox.hpp"
#include "controller/transport/realtime/bus.hpp"
#include "controller/transport/realtime/clock.hpp"
#include "controller/transport/realtime/mailbox.hpp"
#include "controller/transport/realtime/realtime.hpp"
#include "core/kinematics/kinematics.hpp"
#include "core/motion/online_generator.hpp"

namespace chasles::controller {

/// Where the node receives, commands and reports. Three LCM instances in the daemon, so that the
/// loop's publish never waits on a lock another thread holds; one memq:// bus in the tests.
struct Buses {
  Bus& receive;
  Bus& command;
  Bus& status;
};

/// The channels a node listens and speaks on: chasles's with the prefix, and the arm driver's
/// status and command channels as the protocol names them unless the options give them.
Channels channels_of(const DaemonOptions& options);

class Node {
 public:
  /// Keeps references to all four arguments. Throws ArgumentError for a bad config.
  Node(const RobotModel& model, const DaemonOptions& options, const Clock& clock, Buses buses);
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  /// Empty, or why this controller must not start: another sender was heard on the command
  /// channel before this one has sent anything.
  std::string refusal() const;

  /// The first tick's scheduled time: now + one period.
  int64_t first_tick() const;
  /// State-driven: a state has arrived that no tick has read yet (tick now).
  bool state_waiting() const { return inbox_.states.fresh(); }
  /// One tick, scheduled for `scheduled` (it reads the clock for its measurements); returns the
  /// time the next is scheduled for.
  ///   clock-driven: a tick that finishes past the next schedule counts the periods missed and
  ///     starts again from the present rather than run a burst of late ticks;
  ///   state-driven: a tick that reads a new state is timed from that state's arrival, and the
  ///     next is due 1.5 periods after it — the watchdog's tick, if no state comes first.
  int64_t tick(int64_t scheduled);
  /// Builds the model for the newest payload received, if any (the loop takes it at its next
  /// tick), then plans the newest Cartesian request, if any, into a joint path for the loop;
  /// whether anything was handed over (false: nothing to do, or the path waits for room — wait
  /// for the bell).
  bool plan();
  /// Drains the timing records, reports changes on stderr and publishes a status when one is due
  /// (or the mode changed); returns when the next is due.
  int64_t report();
  /// The locator thread's: where on the arm the newest state's τ̂_ext comes from, published as
  /// contact_estimate_t (DaemonOptions::locate); returns when to look again (its bell rings
  /// sooner when the loop has a torque above the floor for it).
  int64_t locate();
  /// The latest estimate published (state NONE before the first); the locator's thread.
  const contact_estimate_t& located() const { return locating_.message; }
  /// The summary of the run so far, over `seconds` of it.
  Summary summary(double seconds);

  void set_realtime_granted(bool granted) { realtime_granted_ = granted; }
  const Controller& controller() const { return loop_.controller; }
  /// Rung when plan() has work: a Cartesian request or room for a waiting path (by the loop), a
  /// payload (by the bus's handler).
  Doorbell& planner_bell() { return planner_bell_; }
  /// Rung by the loop when report() must run before the status is due: a change of mode, a
  /// refused target, a foreign command.
  Doorbell& reporter_bell() { return reporter_bell_; }
  /// Rung by the loop when a state's τ̂_ext is above the locator's floor, or has just fallen under it.
  Doorbell& locator_bell() { return locator_bell_; }

 private:
  // One tick's measurements, queued by the loop for the status step.
  struct TickRecord {
    double jitter_us = 0.0;
    double compute_us = 0.0;   // state read → command encoded
    double publish_us = 0.0;   // the send (LCM hands the datagram to every local subscriber)
    double latency_us = -1.0;  // < 0: the tick answered no new state
    double error_max = 0.0;    // max |e_i|, when the tick commanded
    double error_sq = 0.0;     // Σ e_i²
    bool commanded = false;
  };
  // The loop's own counts, totals since start.
  struct LoopCounters {
    int64_t ticks = 0, overruns = 0, commands = 0, send_failures = 0;
    int64_t lost_records = 0;  // timing records the status step fell too far behind to take
  };
  // What the loop shows the status step, every tick.
  struct Snapshot {
    Mode mode = Mode::kWaiting;
    char fault[192] = {};
    char rejection[192] = {};
    char reflex[192] = {};
    Eigen::VectorXd q, q_desired, error, torque, tau_ext;
    motion::Limits generator;  // the stream generator's limits in force
    Vector6d wrench_ext = Vector6d::Zero();  // base-aligned at the tip
    bool contact = false, collision = false;
    int64_t contacts = 0, reflexes = 0;
    double peak_tip_force = 0.0;
    int ik_iterations = 0;
    double ik_residual = 0.0;
    bool ik_converged = false;
    LoopCounters loop;
    int64_t stale = 0, faults = 0, rejected_targets = 0, foreign_commands = 0;
    Law law = Law::kComputedTorque;
    double payload_mass = 0.0;
    double state_period = 0.0;
    char period_warning[160] = {};
    char mode_rejection[192] = {};
    int64_t rejected_modes = 0;
    bool mode_refused_last = false;  // the newer of the two refusals is the law's
    TrajectoryProgress trajectory;
    bool streaming = false;
    int64_t setpoints = 0, dropped_setpoints = 0;
    bool jogging = false;
    int64_t jogs = 0, dropped_jogs = 0;
    JogProgress jog;
    ClearanceStatus clearance;
    explicit Snapshot(int n = 0);
  };
  // Timing figures of the status window and of the whole run.
  struct Timing {
    Histogram jitter, compute, latency, publish;
    void record(const TickRecord& r);
    void merge(const Timing& other);
    void reset();
  };

  // The model the loop controls with, and the payload it carries (mass 0: none).
  struct LoadedModel {
    RobotModel model;
    Payload payload;
  };
  static LoadedModel loaded(const RobotModel& model, const std::optional<Payload>& payload);

  void stand_down();
  /// The worker's: the newest scene received decoded and built into a world for the loop; false
  /// (said on stderr) when it is refused.
  bool build_scene();
  /// Messages heard on the command channel that this process did not send.
  int64_t foreign_commands() const { return inbox_.own_commands().foreign(); }
  void publish_snapshot();
  /// The loop's: the state just read and its τ̂_ext into the locator's mailbox.
  void hand_to_locator();
  void follow_plant_time(int64_t wake);
  void drain();
  void fill_status();

  const RobotModel& model_;
  DaemonOptions options_;
  const Clock& clock_;
  Buses buses_;
  const int n_;
  const int64_t period_ns_;
  Channels channels_;
  Doorbell planner_bell_, reporter_bell_, locator_bell_;
  Inbox inbox_;
  // Built by the worker from model_ and a payload, swapped in by the loop between ticks; the
  // controller drives the mailbox's front, which the worker never writes.
  Mailbox<LoadedModel> models_;
  Mailbox<Snapshot> snapshots_;
  SpscRing<TickRecord> records_{8192};
  Mailbox<CartesianRequest> requests_;  // loop → IK: only the newest request matters
  // Built by the worker for each scene received, swapped in by the loop between ticks; the
  // controller computes with the front, which the worker never writes.
  Mailbox<std::shared_ptr<ClearanceWorld>> worlds_;
  SpscRing<JointPath> paths_;           // IK → loop
  // loop → locator: the newest state's joint positions and τ̂_ext.
  struct LocateInput {
    Eigen::VectorXd q, tau_ext;
    int64_t utime = 0, seq = 0;
  };
  Mailbox<LocateInput> locate_inputs_;
  Mailbox<contact_estimate_t> located_;  // locator → status: the latest estimate published
  Mailbox<LocatedContact> locations_;    // locator → loop: the latest LOCATED, for the link's policy
  bool realtime_granted_ = false;

  // Each thread's own state, touched by its step alone; the threads meet only in the mailboxes,
  // rings and doorbells above.

  // The real-time loop's: tick() and what it calls.
  struct Loop {
    Loop(const RobotModel& model, const DaemonOptions& options, const Payload& payload);
    Controller controller;
    CommandWriter command_writer;
    // What the driver adds to the torque sent: under kOverlay, g(q) of the bare arm at the state
    // answered — it knows the arm, not a payload chasles was told of, whose weight stays in the
    // torque sent; zero under kFull.
    Eigen::VectorXd driver_gravity;
    JointState state;
    Target target;
    motion::Waypoints waypoints;
    Setpoint setpoint;
    Jog jog;
    TipSetpoint tip_setpoint;
    LawSettings mode;
    Payload payload;
    int64_t modes_seen = 0, targets_seen = 0;  // refused, to tell which refusal came last
    bool mode_refused_last = false;
    CartesianRequest request;
    JointPath path;
    LoopCounters counters;
    bool have_state = false;
    int64_t answered_seq = -1, seq = 0;
    int64_t noticed_rejections = 0, noticed_foreign = 0;  // what the reporter was last rung for
    TrajectoryProgress::Outcome noticed_outcome = TrajectoryProgress::kNone;
    // --simulator: the latest state with its arrival on the plant's clock, and that clock.
    JointState plant_state;
    int64_t plant_ns = 0, plant_offset_ns = 0;
    bool plant_anchored = false;
  } loop_;

  // The IK worker's: plan().
  struct Planner {
    Planner(const RobotModel& model, const motion::LimitConfig& config);
    Payload payload;
    IkSolver solver;
    motion::MotionLimits limits;  // a payload changes no limit
    CartesianRequest request;
    JointPath path;
    bool path_waiting = false;  // planned, not yet taken by the loop
    geometry::Scene scene;
    // The world a Cartesian path is checked in before it goes to the loop, with the worker's own
    // workspaces (the loop computes in the world's): rebuilt with each scene.
    std::shared_ptr<const ClearanceWorld> world;
    std::unique_ptr<geometry::PathChecker> checker;
    std::unique_ptr<geometry::ProximityData> along_path;
    Data data;
    JointPathSampler sampler;
    motion::Reference sampled;
    geometry::JointPath checked;
    /// Checks with `next` from now on (nullptr: nothing to check).
    void use(const RobotModel& model, std::shared_ptr<const ClearanceWorld> next);
    /// Whether `path` (planned, ok) keeps clear; if not, it is failed saying why.
    void check(const RobotModel& model, JointPath& path);
  } planner_;

  // The locator's: locate(). Null locator: no collision geometry, or not asked for.
  struct Locating {
    explicit Locating(const RobotModel& model);
    std::unique_ptr<geometry::ContactLocator> locator;
    Data data;
    contact_estimate_t message;
    std::vector<uint8_t> bytes;
    int64_t next_ns = 0;
    bool located = false;  // the latest published said LOCATED
  } locating_;
  bool above_floor_ = false;  // the loop's: the latest state handed over was above the floor

  // The status step's: report() and summary().
  struct Reporter {
    explicit Reporter(const RobotModel& model);
    Data data;
    Snapshot last;
    bool have_snapshot = false;
    contact_estimate_t located;  // the locator's latest
    Timing window, total;
    double error_sq_sum = 0.0, error_max = 0.0;
    int64_t error_samples = 0;
    controller_status_t status;
    std::vector<uint8_t> status_bytes;
    Mode reported_mode = Mode::kWaiting;
    int64_t reported_rejections = 0, reported_wire = 0, reported_modes = 0, reported_faults = 0;
    int64_t reported_lost = 0;  // messages the receiving bus lost whole
    bool period_warned = false;
    int64_t reported_trajectory = 0;
    TrajectoryProgress::Outcome reported_outcome = TrajectoryProgress::kNone;
    int64_t last_status_ns = INT64_MIN / 2;
  } reporter_;
};

}  // namespace chasles::controller
