#pragma once
// Anchor clock synchronisation of a TDoA system from the sync master's broadcasts (the SEWIO
// scheme of ../shared/reference/004_uwb_kf.md §2.2): the master sends a sync every couple of
// seconds and reports the counter at which it sent it (its `E` record: anchor_id == sender_id ==
// master, is_sync); every other anchor reports the counter at which it received it. Matched by
// (master, seq), anchor rx counter - master tx counter - master-to-anchor time of flight (from
// the site geometry, line of sight assumed as in 004) measures the anchor's clock offset from
// the master's.
//
// Per anchor a two-state Kalman filter tracks that offset and its rate, relative to the master
// (the master's own clock is no better than the others: everything is in master time). It is
// 004's clock KF (§2.3 model 4) applied to timestamps rather than to 004's rate coefficients,
// which also sidesteps 004's k-inversion (its k = anchor interval / master interval then
// multiplies anchor intervals): here anchor elapsed ticks are divided by (1 + rate), the only
// consistent reading. Missed syncs are predicted across; outliers are gated on the innovation
// and counted, and repeated rejections re-acquire the clock (an anchor reboot, a step).
//
// Pure: fed uwb_rx_t sync records, emits clock_t through a callback, never reads a clock.
#include <cstdint>
#include <deque>
#include <functional>
#include <ips/clock_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/consistency.hpp"
#include "core/ekf.hpp"
#include "core/site.hpp"

namespace ips::uwb_tdoa {

struct ClockSyncParams {
  std::string master;  // empty: the sender of the sync broadcasts on the bus
  // Timestamp noise of one sync reception: 004's clock-KF R = 3e-20 s^2 (sqrt = 0.17 ns).
  double sync_sigma_ns = 0.17;
  // Random walk of the rate relative to the master: 004's chosen Q = 5e-22 per 2 s sync for one
  // clock is 0.016 ppb/sqrt(s); two independent clocks (anchor and master) give sqrt(2) times.
  double rate_random_walk_ppb_per_sqrt_s = 0.023;
  // Prior on a new anchor's rate: DW1000 crystals are specified to +-20 ppm.
  double initial_rate_sigma_ppb = 20000.0;
  double gate_sigma = 5.0;             // reject |innovation| > gate_sigma * sqrt(S)
  int reacquire_after_rejections = 3;  // consecutive gated syncs that restart the clock
  int tracking_after_syncs = 2;        // syncs before a clock is used (two give offset and rate)
  double lost_after_s = 10.0;          // no accepted sync this long: lost, re-acquired later
  double match_window_s = 0.5;         // an anchor's sync report waits this long for the master's
};

enum class ClockStatus : int32_t { kTracking = 0, kAcquiring = 1, kLost = 2 };

struct ClockSyncStats {
  int64_t syncs_in = 0;
  int64_t master_records = 0;        // the master's own transmit records
  int64_t syncs_used = 0;            // anchor receptions that updated a clock
  int64_t rejected_gate = 0;         // receptions gated as outliers
  int64_t acquisitions = 0;          // clocks started (first sync, or after lost)
  int64_t reacquisitions = 0;        // clocks restarted after repeated rejections
  int64_t dropped_unmatched = 0;     // receptions whose master record never came
  int64_t dropped_other_master = 0;  // syncs from an anchor that is not the master
  int64_t dropped_late = 0;          // a sync older than the one the clock is at
  int64_t dropped_duplicate = 0;     // a second record for the same (anchor, seq)
  int64_t master_changes = 0;        // the master went silent and another took over
  int64_t time_resets = 0;           // host time went back: every clock restarted
  int64_t clocks_out = 0;
};

// An anchor's reception converted to the master's counter.
struct MasterTime {
  double ticks = 0;   // master counter reading at the reception, [0, 2^40)
  double var_s2 = 0;  // variance of the conversion (the clock estimate's), s^2
};

// An anchor clock estimate as published (clock_t) and read by tests.
struct ClockEstimate {
  std::string anchor_id;
  double offset_s = 0;  // anchor counter - master counter, reduced to [-wrap/2, wrap/2)
  double offset_std_s = 0;
  double rate_ppb = 0;
  double rate_std_ppb = 0;
  int32_t num_syncs = 0;
  ClockStatus status = ClockStatus::kAcquiring;
  utime_t utime = 0;  // host time of the sync it is valid at
};

class ClockSync {
 public:
  using ClockSink = std::function<void(const clock_t&)>;
  explicit ClockSync(ClockSink sink, std::string source = "uwb_tdoa");

  // The enabled uwb_tdoa anchors of the site; resets every clock.
  void configure(const ClockSyncParams& params, const Site& site);
  // An is_sync record (anchor_id, sender_id, seq, rx_counter valid; counter_hz checked by the
  // caller). Records of other anchors than the configured ones are the caller's to filter.
  void on_sync(const uwb_rx_t& m, double counter_hz);
  // Host time went back (the caller's time guard confirmed it): every clock starts again.
  void restart() {
    ++stats_.time_resets;
    reset_clocks();
    newest_master_utime_ = 0;
  }

  // Index of an enabled uwb_tdoa anchor, or -1.
  int anchor_index(const std::string& id) const;
  int num_anchors() const { return static_cast<int>(anchors_.size()); }
  const Eigen::Vector3d& anchor_position(int i) const { return anchors_[i].position; }
  const std::string& anchor_id(int i) const { return anchors_[i].id; }
  int master_index() const { return master_; }  // -1 until known
  const std::string& master_id() const;
  double counter_hz() const { return hz_; }

  // Anchor i's counter reading at host time utime in master counter ticks, when its clock is
  // tracking (the master's own counter is master time); nullopt otherwise.
  std::optional<MasterTime> to_master(int i, int64_t counter, utime_t utime) const;
  std::optional<ClockEstimate> estimate(const std::string& anchor_id) const;
  const ClockSyncStats& stats() const { return stats_; }
  // Checks each anchor's sync innovations in `m` (kind SYNC; with the monitor's learning on, the
  // sync noise is learned per anchor, never below sync_sigma_ns). The monitor must outlive this
  // object; nullptr: none.
  void set_consistency(ConsistencyMonitor* m) { monitor_ = m; }

 private:
  struct MasterRecord {
    int32_t seq;
    int64_t counter;
    utime_t utime;
  };
  struct PendingRx {
    int anchor;
    int32_t seq;
    int64_t counter;
    utime_t utime;
  };
  struct AnchorClock {
    std::string id;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    double tof_s = 0;  // master to this anchor (line of sight)
    bool started = false;
    ClockStatus status = ClockStatus::kAcquiring;
    // offset (anchor - master counter) = base_ticks + x(0) ns; x(1) = rate in ppb. Whole ticks
    // are moved into base after every update so that x(0) stays within a tick.
    int64_t base_ticks = 0;
    Vec<2> x = Vec<2>::Zero();
    Mat<2> P = Mat<2>::Identity();
    int64_t ref_master_counter = 0;  // the state is valid at this master counter reading...
    utime_t ref_utime = 0;           // ...whose record arrived at this host time
    int32_t ref_seq = 0;
    int32_t num_syncs = 0;  // accepted since (re)acquisition
    int consecutive_rejections = 0;
    utime_t last_accept_utime = 0;
  };

  void set_master(int i);
  void reset_clocks();
  void on_master_record(const uwb_rx_t& m);
  void on_reception(int anchor, const uwb_rx_t& m);
  void expire_pending(utime_t now);
  void apply(int anchor, const MasterRecord& rec, int64_t rx_counter);
  void acquire(AnchorClock& a, const MasterRecord& rec, int64_t rx_counter);
  void publish(const AnchorClock& a, utime_t utime);
  ClockEstimate make_estimate(const AnchorClock& a) const;
  double q_ppb2_per_s() const;

  ClockSink sink_;
  std::string source_;
  ClockSyncParams params_;
  double hz_ = 63.8976e9;
  std::vector<AnchorClock> anchors_;
  int master_ = -1;
  int32_t master_records_seen_ = 0;
  std::deque<MasterRecord> master_records_;  // the newest few, for matching
  std::deque<PendingRx> pending_;            // receptions waiting for their master record
  utime_t newest_master_utime_ = 0;
  ClockSyncStats stats_;
  ConsistencyMonitor* monitor_ = nullptr;
  std::string sync_setting_;  // "sync_sigma_ns 0.17"
};

}  // namespace ips::uwb_tdoa
