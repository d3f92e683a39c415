// The tracker's per-joint filter: a one-euro filter (Casiez, Roussel and Vogel,
// CHI 2012) on the joint's 3-D position whose speed is measured robustly, so that
// a still joint stays still on a noisy sensor and a moving one follows.
//
// A plain one-euro filter estimates speed from one frame to the next: on a Kinect
// v1 at 3 m that is mostly the sensor's jitter (several cm a frame), which opens
// the filter for a person who stands still. Here the speed is the distance
// between the means of the last two blocks of samples (block_s each), less a
// dead zone (the speed the jitter alone gives such block means); below it the
// cutoff is min_cutoff, above it grows by beta per m/s. The output keeps the
// input's time: the filter changes positions, never stamps.
#pragma once

#include <deque>

#include "hri_sync/body.h"

namespace hri_sync {

struct JointFilterParams {
  double min_cutoff = 0.3;    ///< Hz, the cutoff of a still joint
  double beta = 4.0;          ///< Hz per m/s of speed above the dead zone
  double dead_zone = 0.3;     ///< m/s of block-mean speed taken as jitter
  double block_s = 0.133;     ///< s per block of the speed estimate
  double speed_cutoff = 1.0;  ///< Hz, the low-pass on the speed estimate
};

class JointFilter {
 public:
  /// One sample at time t (s); returns the filtered position. A time not after
  /// the last one starts the filter over from this sample.
  Vec3 filter(const Vec3& p, double t, const JointFilterParams& params);
  /// The filtered position (the last output).
  const Vec3& value() const { return x_; }
  void reset();

 private:
  struct Sample {
    Vec3 p;
    double t;
  };
  bool init_ = false;
  Vec3 x_;
  double t_ = 0;
  double speed_ = 0;          ///< low-passed block-mean speed, m/s
  std::deque<Sample> history_;
};

}  // namespace hri_sync
