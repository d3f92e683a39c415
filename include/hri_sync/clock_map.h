// The tracker's clocks, named as everywhere in hri_sync: a sensor's own
// **device** clock, the process's **local** clock (CLOCK_REALTIME, possibly
// faked) and the time server's **global** clock (the fourth, **true**, is
// the host's real clock, ground truth in tests). DeviceClockMapper maps
// device stamps to the clock their arrivals are stamped in (the local clock,
// in the tracker); ClockModel maps local to global time as the CPM's
// hri_sync/ClockState describes it.
#pragma once

#include <cstddef>
#include <deque>
#include <limits>
#include <string>

namespace hri_sync {

/// The device clock map of Python's hri_sync.data_process.capture.DeviceClockMapper,
/// the same algorithm and parameters (test/data/clock_map/ checks both):
/// arrival - device = true offset + transport delay >= true offset, so the
/// offset is the lower envelope of those values over the last `window_s` of
/// device time: the Theil-Sen line through the minima of ~1 s bins (4 to 30
/// bins over the span), shifted down so no sample is below it; under
/// `min_span_s` of samples, the minimum with no drift. A device clock that
/// goes back (a looping recording, a restarted sensor) starts the fit over and
/// counts in resets(). Until a fit holds `settle` samples it is not ready():
/// alone, one sample held by a stalled reader would set the offset that late.
class DeviceClockMapper {
 public:
  explicit DeviceClockMapper(double window_s = 30.0, double min_span_s = 5.0, size_t settle = 5)
      : window_s_(window_s), min_span_s_(min_span_s), settle_(settle) {}

  /// Adds one sample: its device stamp and its arrival time (s).
  void observe(double device, double arrival);
  /// Forgets every sample (a new device); not counted in resets().
  void reset();
  /// Whether the fit holds enough samples to map stamps.
  bool ready() const { return points_.size() >= settle_; }
  /// The arrivals' clock (the local clock, in the tracker) at a device stamp;
  /// throws std::logic_error before the first observe().
  double toLocal(double device) const;

  /// arrival - device at ref() (s).
  double offset() const { return offset_; }
  /// d(arrival - device)/d(device): minus the device clock's rate error.
  double drift() const { return drift_; }
  double ref() const { return ref_; }
  /// How often the device clock went back.
  unsigned long resets() const { return resets_; }
  size_t samples() const { return points_.size(); }
  /// Mean arrival delay above the map of the recent samples (s), a diagnostic.
  double meanDelay() const { return mean_delay_; }

 private:
  struct Point { double device, lag; };  // lag = arrival - device
  void fit();

  double window_s_, min_span_s_;
  size_t settle_;
  std::deque<Point> points_;
  bool fitted_ = false;
  double offset_ = 0, drift_ = 0, ref_ = 0, mean_delay_ = 0, delay_sum_ = 0;
  size_t delay_n_ = 0;
  unsigned long resets_ = 0;
};

/// A linear map from local to global time, as Python's
/// hri_sync.clock.model.ClockModel:
/// global(local) = local + offset + drift * (local - local_ref).
/// The default is the identity with an unbounded uncertainty, as in Python.
struct ClockModel {
  double local_ref = 0, offset = 0, drift = 0, uncertainty = std::numeric_limits<double>::infinity();
  double offsetAt(double local) const { return offset + drift * (local - local_ref); }
  double toGlobal(double local) const { return local + offsetAt(local); }
  double toLocal(double global) const { return (global - offset + drift * local_ref) / (1.0 + drift); }
};

/// A client's global clock as its CPM publishes it (hri_sync/ClockState),
/// checked: ready only when the CPM says ok and the model is usable;
/// otherwise `reason` says why.
struct ClockStatus {
  bool ready = false;
  std::string reason = "no clock_state received yet";
  ClockModel model;
};

/// The limits of a usable model, as Python's hri_sync.clock.model:
/// |drift| <= kMaxDrift (MAX_DRIFT, 1 %: ten times any crystal's), local_ref
/// and its global time in [0, kTimeLimit) (TIME_LIMIT, 2^32 s: what a ROS
/// time can carry; Python's rule is hri_sync.wire.times.fits_ros_time).
constexpr double kMaxDrift = 0.01;
constexpr double kTimeLimit = 4294967296.0;

/// The one ClockState -> ClockModel conversion of the C++ side, with the
/// checks and reasons of Python's hri_sync.clock.ros_clock_state.model_from_msg:
/// the CPM's reason when it is not ok; a value that is not finite, a
/// negative uncertainty, a drift or time outside the limits above, named.
ClockStatus clockStatus(const std::string& client_id, bool ok, const std::string& reason, double local_ref,
                        double offset, double drift, double uncertainty);

/// The same from an hri_sync/ClockState message (kept out of this ROS-free
/// header's dependencies by the template).
template <class ClockStateMsg>
ClockStatus clockStatus(const ClockStateMsg& m) {
  return clockStatus(m.client_id, m.ok, m.reason, m.local_ref, m.offset, m.drift, m.uncertainty);
}

}  // namespace hri_sync
