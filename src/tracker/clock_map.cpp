#include "hri_sync/clock_map.h"

#include <algorithm>
#include <cmath>

namespace hri_sync {

void DeviceClockMapper::reset() {
  buckets_.clear();
  samples_ = 0;
  offset_ = drift_ = ref_ = mean_delay_ = lag_sum_ = 0;
  lag_n_ = 0;
}

bool DeviceClockMapper::add(double device_s, double host_s, double max_gap_s) {
  bool continuous = true;
  if (samples_ > 0 && (device_s <= last_device_ || device_s - last_device_ > max_gap_s)) {
    reset();
    continuous = false;
  }
  last_device_ = device_s;
  ++samples_;
  const double lag = host_s - device_s;
  if (buckets_.empty() || device_s - buckets_.back().device >= bucket_s_) {
    buckets_.push_back({device_s, lag});
  } else if (lag < buckets_.back().lag) {
    buckets_.back() = {device_s, lag};
  }
  while (buckets_.size() > 2 && device_s - buckets_.front().device > window_s_) buckets_.pop_front();
  fit();
  lag_sum_ += host_s - toHost(device_s);
  ++lag_n_;
  mean_delay_ = lag_sum_ / lag_n_;
  if (lag_n_ > 300) { lag_sum_ = mean_delay_ * 100; lag_n_ = 100; }
  return continuous;
}

void DeviceClockMapper::fit() {
  ref_ = buckets_.back().device;
  // Complete buckets only define the slope; the newest may hold one frame yet.
  const size_t n = buckets_.size();
  if (n < 4) {
    double lo = buckets_.front().lag;
    for (const auto& b : buckets_) lo = std::min(lo, b.lag);
    offset_ = lo;
    drift_ = 0;
    return;
  }
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& b : buckets_) {
    double x = b.device - ref_;
    sx += x; sy += b.lag; sxx += x * x; sxy += x * b.lag;
  }
  double den = n * sxx - sx * sx;
  double slope = den > 1e-12 ? (n * sxy - sx * sy) / den : 0.0;
  slope = std::clamp(slope, -1e-3, 1e-3);  // no real clock is off by more than 1000 ppm
  // Lower envelope: shift the line down to the lowest bucket.
  double lo = 1e18;
  for (const auto& b : buckets_) lo = std::min(lo, b.lag - slope * (b.device - ref_));
  offset_ = lo;
  drift_ = slope;
}

}  // namespace hri_sync
