// Mapping of a sensor's device timestamps to host time and then to the
// client's global clock.
#pragma once

#include <cstddef>
#include <deque>
#include <string>

namespace hri_sync {

/// Estimates host = device + offset + drift * (device - ref) from (device stamp,
/// host arrival) pairs by a minimum-delay fit: a frame can arrive late, never
/// early, so the line follows the lower envelope of (host - device), not each
/// frame's arrival.
class DeviceClockMapper {
 public:
  explicit DeviceClockMapper(double window_s = 60.0, double bucket_s = 1.0)
      : window_s_(window_s), bucket_s_(bucket_s) {}

  /// Adds one frame; returns false (and starts over) when the device clock
  /// jumped (backwards, or forwards by more than max_gap_s): a restart or a loop.
  bool add(double device_s, double host_s, double max_gap_s = 10.0);
  void reset();
  bool ready() const { return samples_ >= 5; }
  double toHost(double device_s) const { return device_s + offset_ + drift_ * (device_s - ref_); }
  double offset() const { return offset_; }
  double drift() const { return drift_; }
  /// Mean arrival delay over the envelope of the recent frames (s).
  double meanDelay() const { return mean_delay_; }
  size_t samples() const { return samples_; }

 private:
  struct Bucket { double device, lag; };   // the minimum-lag frame of a bucket
  void fit();

  double window_s_, bucket_s_;
  std::deque<Bucket> buckets_;
  size_t samples_ = 0;
  double last_device_ = 0;
  double offset_ = 0, drift_ = 0, ref_ = 0, mean_delay_ = 0, lag_sum_ = 0;
  size_t lag_n_ = 0;
};

/// A client's global clock as its CPM publishes it (hri_sync/ClockState):
/// global(local) = local + offset + drift * (local - local_ref).
struct GlobalClockModel {
  bool ok = false;
  std::string reason = "no clock_state received yet";
  double local_ref = 0, offset = 0, drift = 0, uncertainty = 0;
  double toGlobal(double local) const { return local + offset + drift * (local - local_ref); }
};

}  // namespace hri_sync
