#include "hri_sync/pose_fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "hri_sync/render.h"

namespace hri_sync {

namespace {

constexpr int kNumParts = kBodyParts.size() + 1;
constexpr double kLengthPrior = 1e-3;  // prior energy per kept frame per (log of a length's scale)^2
constexpr double kOverRelax = 2.0;  // steps beyond the mean pull converge in fewer iterations
constexpr double kFloorBand = 0.06;  // segmentUser drops points within 5 cm of the floor (+1 cm noise)
// A leg seen down to this height stands: the floor band hides its foot, whose
// sole is then on the floor, pulled there with this many points' weight.
constexpr double kStandsBelow = kFloorBand + 0.03;
constexpr double kGroundWeight = 10.0;
constexpr double kGroundReach = 0.15;  // only a foot joint this low is pulled
// The head ball's centre above the head joint: a ball of kHeadRadius fits a
// head (a crown ball, the face below and before it) best 2 cm above the joint
// seen from the front, 3.5 cm from the side, 4.5 cm from behind.
constexpr double kFitHeadAbove = 0.03;
constexpr double kDepthNoise = 1.25 * 2.85e-3;  // a Kinect v1's depth noise at z: this times z^2 (m)

// Per-joint weighted sums of displacements.
struct Pull {
  std::array<Vec3, NUM_JOINTS> sum;
  std::array<double, NUM_JOINTS> weight{};
  void add(const BodyPart& p, double t, const Vec3& delta, double w) {
    addEnd(p.a, delta, w * (1 - t));
    addEnd(p.b, delta, w * t);
  }
  void addEnd(const CapsuleEnd& end, const Vec3& delta, double w) {
    if (w <= 0) return;  // a share outside 0..1 (the head sphere beyond the head) moves one joint
    addJoint(end.i, delta, w * std::clamp(1 - end.w, 0.0, 1.0));
    addJoint(end.k, delta, w * std::clamp(end.w, 0.0, 1.0));
  }
  void addJoint(int j, const Vec3& delta, double w) {
    sum[j] += delta * w;
    weight[j] += std::fabs(w);
  }
};

// The pull of each standing foot's sole to the floor (lowest: the height of
// the lowest depth point on each leg's shin and foot); returns its energy.
double ground(const Plane& floor, const Joints& j, const std::array<double, 2>& lowest, Pull* pull) {
  double energy = 0;
  for (int side = 0; side < 2; ++side) {
    if (lowest[side] > kStandsBelow) continue;
    const int foot = side == 0 ? L_FOOT : R_FOOT;
    const double h = floor.height(j[foot]);
    if (h > kGroundReach) continue;  // a foot held up, whatever its leg's lowest point
    energy += kGroundWeight * h * h;
    if (pull) pull->addJoint(foot, floor.n * -h, kGroundWeight);
  }
  return energy;
}

// The arm (0 left, 1 right) a capsule moves, or -1: an arm capsule's points
// support its joints only when no other capsule explains them nearly as well.
int armOf(const BodyPart& p) {
  for (int side = 0; side < 2; ++side) {
    const int elbow = side == 0 ? L_ELBOW : R_ELBOW, hand = side == 0 ? L_HAND : R_HAND;
    for (const CapsuleEnd& e : {p.a, p.b})
      if (e.i == elbow || e.i == hand || e.k == elbow || e.k == hand) return side;
  }
  return -1;
}

}  // namespace

PoseFitter::PoseFitter(const Camera& cam, const PointGrid& g, const Segmentation& seg, const Plane& floor,
                       const BodyModel& m, const PoseFitParams& p)
    : cam_(cam), g_(g), seg_(seg), floor_(floor), p_(p) {
  // The head ball a fixed distance beyond the head joint, whatever the neck's
  // length: the best ball for a head whose face lies below and before the crown.
  const double beyond = -kFitHeadAbove / std::max(m.head_to_neck, 0.02);
  head_ = {{HEAD, NECK, beyond}, {HEAD, NECK, beyond}, kHeadRadius};
  parts_ = kBodyParts;
  for (BodyPart& part : parts_)
    if (part.girth) part.radius *= m.girth;
  // Nearest user cell of every grid cell (multi-source breadth-first search).
  nearest_.assign(g.width * g.height, -1);
  std::vector<int> queue(seg.cells.begin(), seg.cells.end());
  for (int c : seg.cells) nearest_[c] = c;
  for (size_t q = 0; q < queue.size(); ++q) {
    int i = queue[q], x = i % g.width, y = i / g.width;
    const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const auto& d : nb) {
      int nx = x + d[0], ny = y + d[1];
      if (nx < 0 || ny < 0 || nx >= g.width || ny >= g.height) continue;
      int j = ny * g.width + nx;
      if (nearest_[j] >= 0) continue;
      nearest_[j] = nearest_[i];
      queue.push_back(j);
    }
  }
  // The torso is rigid in the model's shape; limbs keep their bone lengths.
  Joints rest;
  rest[TORSO] = Vec3(0, 0, 0);
  rest[NECK] = Vec3(0, m.torso_to_neck, 0);
  rest[L_SHOULDER] = Vec3(m.shoulder_width / 2, m.torso_to_neck - m.neck_drop, 0);
  rest[R_SHOULDER] = Vec3(-m.shoulder_width / 2, m.torso_to_neck - m.neck_drop, 0);
  rest[L_HIP] = Vec3(m.hip_width / 2, -m.torso_to_hips, 0);
  rest[R_HIP] = Vec3(-m.hip_width / 2, -m.torso_to_hips, 0);
  const int trunk[] = {NECK, TORSO, L_SHOULDER, R_SHOULDER, L_HIP, R_HIP};
  for (int a = 0; a < 6; ++a)
    for (int b = a + 1; b < 6; ++b)
      bones_.push_back({trunk[a], trunk[b], (rest[trunk[a]] - rest[trunk[b]]).norm(), 0.5});
  bones_.push_back({NECK, HEAD, m.head_to_neck, 0.2});
  bones_.push_back({L_SHOULDER, L_ELBOW, m.upper_arm, 0.2});
  bones_.push_back({R_SHOULDER, R_ELBOW, m.upper_arm, 0.2});
  bones_.push_back({L_ELBOW, L_HAND, m.forearm, 0.5});
  bones_.push_back({R_ELBOW, R_HAND, m.forearm, 0.5});
  bones_.push_back({L_HIP, L_KNEE, m.thigh, 0.2});
  bones_.push_back({R_HIP, R_KNEE, m.thigh, 0.2});
  bones_.push_back({L_KNEE, L_FOOT, m.shin, 0.5});
  bones_.push_back({R_KNEE, R_FOOT, m.shin, 0.5});
}

// Over 80 lines: one pass of the fit over every depth point (assign each
// to its nearest capsule, accumulate the pulls, move the joints), kept in one
// loop because it is the tracker's hot path.
double PoseFitter::step(Joints* j, std::vector<int8_t>* hint, std::array<int, NUM_JOINTS>* support,
                        bool move) const {
  const Joints& pose = *j;
  std::array<Vec3, kNumParts * 2> ends;
  std::array<Vec3, kNumParts> axis;  // end a to end b
  std::array<double, kNumParts> reach;  // bounding sphere: no surface point is farther from centre
  std::array<double, kNumParts> len2, radius;
  std::array<int, kNumParts> arm_of;  // the arm each capsule moves (armOf), or -1
  // The centres, one array per coordinate: the bounding-sphere test of a
  // point against every capsule runs as one vectorised loop.
  std::array<double, kNumParts> cx, cy, cz;
  for (int c = 0; c < kNumParts; ++c) {
    ends[2 * c] = part(c).a.at(pose);
    ends[2 * c + 1] = part(c).b.at(pose);
    const Vec3 centre = (ends[2 * c] + ends[2 * c + 1]) * 0.5;
    cx[c] = centre.x;
    cy[c] = centre.y;
    cz[c] = centre.z;
    axis[c] = ends[2 * c + 1] - ends[2 * c];
    len2[c] = axis[c].dot(axis[c]);
    radius[c] = part(c).radius;
    reach[c] = axis[c].norm() * 0.5 + radius[c];
    arm_of[c] = armOf(part(c));
  }
  Pull pull;
  double energy = 0;
  const double tau = p_.outlier;
  std::array<double, 2> lowest{1e9, 1e9};  // per foot (left, right): its lowest point's height
  // A point's distance to capsule c's surface; t: the closest point's place
  // on its axis (0..1).
  auto surface = [&](const Vec3& pt, int c, double* t) {
    const Vec3 ap = pt - ends[2 * c];
    *t = len2[c] < 1e-12 ? 0.0 : std::clamp(ap.dot(axis[c]) / len2[c], 0.0, 1.0);
    return (pt - (ends[2 * c] + axis[c] * *t)).norm() - radius[c];
  };
  // A point on an arm capsule that another part (the trunk it lies on, the
  // other arm) explains within the depth margin as well is no sign of where
  // the arm is.
  auto explainsAlone = [&](const Vec3& pt, double d, int arm) {
    // The fit's depth margin, or a Kinect v1's depth noise there if more
    // (1.25 depth steps of 2.85e-3 z^2: 5.7 cm at 4 m).
    const double margin = std::max(p_.margin, kDepthNoise * pt.z * pt.z);
    double t;
    for (int c = 0; c < kNumParts; ++c)
      if (arm_of[c] != arm && surface(pt, c, &t) < d + margin) return false;
    return true;
  };
  // Data: every user point lies on the surface of its nearest capsule.
  for (size_t n = 0; n < seg_.cells.size(); ++n) {
    const Vec3& pt = g_.points[seg_.cells[n]];
    int best = -1;
    double best_d = 1e18, best_t = 0;
    auto consider = [&](int c) {
      double t;
      const double d = surface(pt, c, &t);
      if (d < best_d) { best_d = d; best = c; best_t = t; }
    };
    // Last iteration's capsule first: its distance prunes most others.
    const int first = (*hint)[n];
    if (first >= 0) consider(first);
    std::array<double, kNumParts> off2;  // squared distance to each centre (as Vec3::dot)
    for (int c = 0; c < kNumParts; ++c) {
      const double dx = pt.x - cx[c], dy = pt.y - cy[c], dz = pt.z - cz[c];
      off2[c] = dx * dx + dy * dy + dz * dz;
    }
    for (int c = 0; c < kNumParts; ++c) {
      if (c == first) continue;
      const double bound = best_d + reach[c];  // nearer than best_d only within this of the centre
      if (bound < 1e9 && (bound <= 0 || off2[c] >= bound * bound)) continue;
      consider(c);
    }
    (*hint)[n] = static_cast<int8_t>(best);
    energy += std::min(best_d * best_d, tau * tau);
    const CapsuleEnd& low = part(best).b;  // a shin's lower half or a foot ball
    if ((low.i == L_FOOT || low.i == R_FOOT) && best_t > 0.5 && floor_.found) {
      double& l = lowest[low.i == L_FOOT ? 0 : 1];
      l = std::min(l, floor_.height(pt));
    }
    if (support) {
      const BodyPart& p = part(best);
      const int joint = best_t < 0.5 ? p.a.i : p.b.i;
      if (arm_of[best] < 0 || explainsAlone(pt, best_d, arm_of[best])) ++(*support)[joint];
    }
    if (!move) continue;
    Vec3 axis = ends[2 * best] + (ends[2 * best + 1] - ends[2 * best]) * best_t;
    Vec3 dir = (pt - axis).normalized();
    double w = std::fabs(best_d) < tau ? 1.0 : tau / std::fabs(best_d);
    pull.add(part(best), best_t, dir * best_d, w);
  }
  const double n_points = std::max<size_t>(1, seg_.cells.size());
  // Free space: the model's surface facing the sensor must not lie in front of
  // what the sensor sees, nor off the user's silhouette.
  double fs_energy = 0;
  for (int c = 0; c < kNumParts; ++c) {
    const double r = radius[c];
    const Vec3& a = ends[2 * c];
    const Vec3 ax = axis[c].normalized();
    const int samples = std::clamp(static_cast<int>(axis[c].norm() / 0.06), 1, 8);
    for (int s = 0; s <= samples; ++s) {
      double t = static_cast<double>(s) / samples;
      Vec3 q = a + axis[c] * t;
      Vec3 view = (q * -1.0).normalized();
      Vec3 toward = (view - ax * view.dot(ax)).normalized();
      Vec3 across = ax.norm() > 0 ? ax.cross(view).normalized() : Vec3(1, 0, 0).cross(view).normalized();
      for (const Vec3& off : {toward * r, across * (0.8 * r), across * (-0.8 * r)}) {
        Vec3 sp = q + off;
        if (sp.z < 0.3) continue;
        double u, v;
        cam_.project(sp, &u, &v);
        int x = static_cast<int>(std::floor((u + 0.5) / g_.step)), y = static_cast<int>(std::floor((v + 0.5) / g_.step));
        if (x < 0 || y < 0 || x >= g_.width || y >= g_.height) continue;
        int i = y * g_.width + x;
        Vec3 delta;
        if (seg_.mask[i]) {
          double z = g_.points[i].z;
          if (sp.z > z - p_.margin) continue;  // on or behind the seen surface
          delta = sp * (z / sp.z) - sp;
        } else {
          if (g_.ok(i) && g_.points[i].z < sp.z - p_.margin) continue;  // hidden behind something else
          // The floor band: the segmentation removed the user's points there too.
          if (g_.ok(i) && floor_.found && floor_.height(g_.points[i]) < kFloorBand) continue;
          if (nearest_[i] < 0) continue;
          const Vec3& n = g_.points[nearest_[i]];
          delta = n * (sp.z / n.z) - sp;  // to the silhouette, at the model's depth
        }
        double d = delta.norm();
        fs_energy += std::min(d * d, tau * tau);
        if (move) pull.add(part(c), t, delta, p_.free_space * (d < tau ? 1.0 : tau / d));
      }
    }
  }
  energy += p_.free_space * fs_energy;
  if (p_.ground) energy += ground(floor_, *j, lowest, move ? &pull : nullptr);
  energy /= n_points;
  if (!move) return energy;
  for (int k = 0; k < NUM_JOINTS; ++k) (*j)[k] += pull.sum[k] * (kOverRelax / (pull.weight[k] + p_.stiffness));
  constrain(j);
  return energy;
}

void PoseFitter::constrain(Joints* j) const {
  for (int pass = 0; pass < 4; ++pass) {
    for (const Bone& b : bones_) {
      Vec3 d = (*j)[b.b] - (*j)[b.a];
      double l = d.norm();
      if (l < 1e-9) continue;
      Vec3 corr = d * ((l - b.length) / l);
      (*j)[b.a] += corr * b.wa;
      (*j)[b.b] += corr * -(1 - b.wa);
    }
  }
  if (!floor_.found) return;
  // The soles may touch the floor; every other joint is 5 cm above it.
  for (int k = 0; k < NUM_JOINTS; ++k) {
    const double lowest = k == L_FOOT || k == R_FOOT ? 0.0 : 0.05;
    const double h = floor_.height((*j)[k]);
    if (h < lowest) (*j)[k] += floor_.n * (lowest - h);
  }
}

PoseFit PoseFitter::fit(const Joints& init, int iterations) const {
  PoseFit out;
  out.joints = init;
  constrain(&out.joints);
  std::vector<int8_t> hint(seg_.cells.size(), -1);
  for (int it = 0; it < (iterations > 0 ? iterations : p_.iterations); ++it) step(&out.joints, &hint, nullptr, true);
  out.energy = step(&out.joints, &hint, &out.support, false);
  return out;
}

PoseFit PoseFitter::fitMixed(const Joints& init, const std::vector<const Joints*>& alternatives) const {
  // init is usually a fitted pose already: fitting it again is deliberate,
  // its further iterations lower the salsa clips' mean error by 3-7 mm.
  PoseFit best = fit(init);
  const int limbs[4][3] = {{L_SHOULDER, L_ELBOW, L_HAND}, {R_SHOULDER, R_ELBOW, R_HAND},
                           {L_HIP, L_KNEE, L_FOOT}, {R_HIP, R_KNEE, R_FOOT}};
  for (const auto& limb : limbs) {
    for (const Joints* alt : alternatives) {
      const Vec3 shift = best.joints[limb[0]] - (*alt)[limb[0]];
      if (((*alt)[limb[2]] + shift - best.joints[limb[2]]).norm() < 0.1) continue;  // the same limb
      Joints cand = best.joints;
      cand[limb[1]] = (*alt)[limb[1]] + shift;
      cand[limb[2]] = (*alt)[limb[2]] + shift;
      PoseFit f = fit(cand, p_.iterations / 2);
      if (f.energy < best.energy) best = f;
    }
  }
  return best;
}

namespace {

// The lengths (and the girth) the search scales, in order.
double BodyModel::* const kLengths[] = {&BodyModel::thigh,         &BodyModel::shin,
                                        &BodyModel::upper_arm,     &BodyModel::forearm,
                                        &BodyModel::torso_to_neck, &BodyModel::torso_to_hips,
                                        &BodyModel::shoulder_width, &BodyModel::hip_width,
                                        &BodyModel::head_to_neck,  &BodyModel::girth};
constexpr int kNumLengths = sizeof(kLengths) / sizeof(kLengths[0]);
constexpr double kSearchSteps[] = {0.08, 0.04};  // relative scale steps, coarse then fine
constexpr int kSearchRounds = 3;                  // passes over the lengths per step

}  // namespace

BodyModel towards(const BodyModel& from, const BodyModel& to, double max_step) {
  BodyModel out = from;
  for (auto len : kLengths) {
    const double lo = from.*len * (1 - max_step), hi = from.*len * (1 + max_step);
    out.*len = std::clamp(to.*len, lo, hi);
  }
  return out;
}

ModelSearch::ModelSearch(const Camera& cam, std::vector<FitFrame> frames, const BodyModel& start, bool grow_arms)
    : cam_(cam), frames_(std::move(frames)), prior_(start), best_(start), cand_(start), grow_arms_(grow_arms) {
  done_ = frames_.empty();
}

bool ModelSearch::advance(int fits) {
  PoseFitParams p;
  p.iterations = 8;
  p.ground = true;
  for (int k = 0; k < fits && !done_; ++k) {
    const FitFrame& f = frames_[frame_];
    cand_e_ += PoseFitter(cam_, f.grid, f.seg, f.floor, cand_, p).fit(f.init).energy;
    if (++frame_ < frames_.size()) continue;
    // Fit energy plus a prior that keeps each length near the body proportions.
    for (auto len : kLengths) {
      double s = std::log(cand_.*len / prior_.*len);
      cand_e_ += kLengthPrior * frames_.size() * s * s;
    }
    next(cand_e_);
    frame_ = 0;
    cand_e_ = 0;
  }
  return done_;
}

void ModelSearch::next(double energy) {
  // Coordinate descent: each length scaled up, else down, by the step; a
  // change that lowers the energy is kept and the next length is tried.
  if (dir_ < 0) {  // the start, evaluated
    best_e_ = energy;
    dir_ = 0;
  } else if (energy >= best_e_ && dir_ == 0) {
    dir_ = 1;
  } else {
    if (energy < best_e_) {
      best_ = cand_;
      best_e_ = energy;
      moved_ = true;
    }
    dir_ = 0;
    if (++param_ == kNumLengths) {
      param_ = 0;
      if (!moved_ || ++round_ == kSearchRounds) {
        round_ = 0;
        if (++step_ == static_cast<int>(sizeof(kSearchSteps) / sizeof(kSearchSteps[0]))) {
          done_ = true;
          return;
        }
      }
      moved_ = false;
    }
  }
  cand_ = best_;
  const bool arm = kLengths[param_] == &BodyModel::upper_arm || kLengths[param_] == &BodyModel::forearm;
  if (arm && !grow_arms_ && dir_ == 0) dir_ = 1;  // straight to scaling down
  cand_.*kLengths[param_] *= 1 + (dir_ == 0 ? 1 : -1) * kSearchSteps[step_];
}

}  // namespace hri_sync
