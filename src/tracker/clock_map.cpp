#include "hri_sync/clock_map.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hri_sync {
namespace {

/// Python's statistics.median: the middle value, or the mean of the two.
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

}  // namespace

void DeviceClockMapper::reset() {
  points_.clear();
  fitted_ = false;
  offset_ = drift_ = ref_ = mean_delay_ = delay_sum_ = 0;
  delay_n_ = 0;
}

void DeviceClockMapper::observe(double device, double arrival) {
  if (!points_.empty() && device < points_.back().device) {
    points_.clear();
    ++resets_;
  }
  points_.push_back({device, arrival - device});
  while (!points_.empty() && points_.front().device < device - window_s_) points_.pop_front();
  fit();
  fitted_ = true;
  delay_sum_ += arrival - toLocal(device);
  ++delay_n_;
  mean_delay_ = delay_sum_ / delay_n_;
  if (delay_n_ > 300) {  // forget slowly: a mean over the last few hundred samples
    delay_sum_ = mean_delay_ * 100;
    delay_n_ = 100;
  }
}

double DeviceClockMapper::toLocal(double device) const {
  if (!fitted_) throw std::logic_error("no sample observed yet");
  return device + offset_ + drift_ * (device - ref_);
}

// Step for step as Python's DeviceClockMapper._fit (the vectors' `mapped`
// column holds the two to 10 us; in practice they agree to the last bit).
void DeviceClockMapper::fit() {
  const double first = points_.front().device;
  ref_ = points_.back().device;
  const double span = ref_ - first;
  auto lowest = [this] {
    double lo = points_.front().lag;
    for (const Point& p : points_) lo = std::min(lo, p.lag);
    return lo;
  };
  if (span < min_span_s_) {
    offset_ = lowest();
    drift_ = 0;
    return;
  }
  // Lower envelope: the minimum of each bin (about 1 s wide, at least 4
  // bins), then the Theil-Sen line through the minima: the median of their
  // pairwise slopes, so a bin holding only late samples (a sensor or reader
  // that stalled) cannot tilt it.
  const int bins = std::min(30, std::max(4, static_cast<int>(span)));
  std::vector<Point> best(bins);  // device - ref, lag
  std::vector<bool> seen(bins, false);
  for (const Point& p : points_) {
    const int k = std::min(bins - 1, static_cast<int>((p.device - first) / span * bins));
    if (!seen[k] || p.lag < best[k].lag) best[k] = {p.device - ref_, p.lag};
    seen[k] = true;
  }
  std::vector<Point> mins;
  for (int k = 0; k < bins; ++k) {
    if (seen[k]) mins.push_back(best[k]);
  }
  if (mins.size() < 2) {
    offset_ = lowest();
    drift_ = 0;
    return;
  }
  std::vector<double> slopes;
  for (size_t i = 0; i < mins.size(); ++i) {
    for (size_t j = i + 1; j < mins.size(); ++j) {
      if (mins[j].device != mins[i].device) {
        slopes.push_back((mins[j].lag - mins[i].lag) / (mins[j].device - mins[i].device));
      }
    }
  }
  // A device clock is a crystal: a slope past kMaxDrift is delay that
  // changed (a producer that fell behind and caught up), not drift.
  drift_ = std::clamp(slopes.empty() ? 0.0 : median(slopes), -kMaxDrift, kMaxDrift);
  std::vector<double> bases;
  for (const Point& m : mins) bases.push_back(m.lag - drift_ * m.device);
  const double base = median(bases);
  // Shift the line down onto the envelope (no point below it).
  double shift = std::numeric_limits<double>::infinity();
  for (const Point& p : points_) shift = std::min(shift, p.lag - (base + drift_ * (p.device - ref_)));
  offset_ = base + shift;
}

namespace {

/// The shortest text that reads back as `v` (as Python's repr, near enough).
std::string num(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

/// Why a model is not usable, or "" (Python's ClockModel.validate).
std::string invalid(const ClockModel& m) {
  const std::pair<const char*, double> fields[] = {
      {"local_ref", m.local_ref}, {"offset", m.offset}, {"drift", m.drift}, {"uncertainty", m.uncertainty}};
  for (const auto& f : fields) {
    if (!std::isfinite(f.second)) return std::string("clock model ") + f.first + "=" + num(f.second) + " is not finite";
  }
  const std::pair<const char*, double> times[] = {{"local_ref", m.local_ref},
                                                  {"global time at local_ref", m.local_ref + m.offset}};
  for (const auto& t : times) {
    if (!(t.second >= 0 && t.second < kTimeLimit)) {
      return std::string("clock model ") + t.first + "=" + num(t.second) + " s is outside [0, 2**32)";
    }
  }
  if (m.uncertainty < 0) return "clock model uncertainty=" + num(m.uncertainty) + " is negative";
  if (std::fabs(m.drift) > kMaxDrift) return "clock model drift=" + num(m.drift) + " exceeds +/-" + num(kMaxDrift);
  return "";
}

}  // namespace

ClockStatus clockStatus(const std::string& client_id, bool ok, const std::string& reason, double local_ref,
                        double offset, double drift, double uncertainty) {
  const std::string sender = client_id.empty() ? "the sender" : client_id;
  ClockStatus s;
  s.model.local_ref = local_ref;
  s.model.offset = offset;
  s.model.drift = drift;
  s.model.uncertainty = uncertainty;
  if (!ok) {
    s.reason = sender + " has no clock model: " + (reason.empty() ? std::string("no reason given") : reason);
    return s;
  }
  const std::string why = invalid(s.model);
  if (!why.empty()) {
    s.reason = "clock_state of " + sender + ": " + why;
    return s;
  }
  s.ready = true;
  s.reason.clear();
  return s;
}

}  // namespace hri_sync
