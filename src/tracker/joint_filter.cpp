#include "hri_sync/joint_filter.h"

#include <algorithm>
#include <cmath>

namespace hri_sync {

namespace {

double alpha(double cutoff, double dt) { return 1.0 / (1.0 + 1.0 / (2 * M_PI * cutoff * dt)); }

}  // namespace

void JointFilter::reset() {
  init_ = false;
  speed_ = 0;
  history_.clear();
}

Vec3 JointFilter::filter(const Vec3& p, double t, const JointFilterParams& params) {
  if (!init_ || t <= t_) {
    reset();
    init_ = true;
    x_ = p;
    t_ = t;
    history_.push_back({p, t});
    return x_;
  }
  const double dt = t - t_;
  t_ = t;
  history_.push_back({p, t});
  // The two blocks: the samples of the last block_s and of the block_s before.
  const double span = 2 * params.block_s;
  while (history_.size() > 2 && history_.front().t < t - span - 1e-9) history_.pop_front();
  double speed;
  const double mid = t - params.block_s;
  Vec3 sum_new, sum_old;
  int n_new = 0, n_old = 0;
  double t_new = 0, t_old = 0;
  for (const Sample& s : history_) {
    if (s.t > mid) { sum_new += s.p; t_new += s.t; ++n_new; }
    else { sum_old += s.p; t_old += s.t; ++n_old; }
  }
  if (n_new > 0 && n_old > 0 && t_new / n_new > t_old / n_old) {
    speed = (sum_new * (1.0 / n_new) - sum_old * (1.0 / n_old)).norm() / (t_new / n_new - t_old / n_old);
  } else {
    speed = (p - x_).norm() / dt;
  }
  const double as = alpha(params.speed_cutoff, dt);
  speed_ = as * speed + (1 - as) * speed_;
  const double cutoff = params.min_cutoff + params.beta * std::max(0.0, speed_ - params.dead_zone);
  const double a = alpha(cutoff, dt);
  x_ = p * a + x_ * (1 - a);
  return x_;
}

}  // namespace hri_sync
