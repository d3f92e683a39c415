#include "hri_sync/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <tuple>

namespace hri_sync {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHeadTop = 0.145;   // head top above the head joint (m), before scaling
constexpr double kTrackFloor = -1.0;  // floor y of the track frame
// The crowd's body shapes, crowd member 1, 2, 3 (SceneOptions::crowd).
const char* const kCrowdBodies[3] = {"tall_slim", "average", "loose_clothes"};

// Counter-based random numbers: the same (seed, frame, pixel, stream) gives the
// same number whatever order pixels are visited in.
uint64_t mix(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
// A standard normal sample from the top 12 bits of a hash: the quantile of one
// of 4096 equal-probability bins (a table: per pixel this is the renderer's
// hot spot; tails cut at 3.5 sigma).
double gaussian(uint64_t hash) {
  static const std::vector<double> quantiles = [] {
    std::vector<double> q(4096);
    for (size_t i = 0; i < q.size(); ++i) {
      double p = (i + 0.5) / q.size(), lo = -8, hi = 8;  // solve Phi(x) = p by bisection
      for (int k = 0; k < 60; ++k) {
        double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
      }
      q[i] = 0.5 * (lo + hi);
    }
    return q;
  }();
  return quantiles[hash >> 52];
}

void checkRange(const char* what, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%s must be in [%g, %g], not %g", what, lo, hi, v);
    throw std::invalid_argument(buf);
  }
}

Vec3 lerp(const Vec3& a, const Vec3& b, double w) { return a + (b - a) * w; }

// A standard normal field over a W x H image, correlated over a box window
// width_px wide (fractional widths: the end taps are weighted), unit variance:
// white noise from the hash key, box-filtered along rows and columns.
std::vector<float> correlatedField(uint64_t key, int W, int H, double width_px) {
  const size_t N = static_cast<size_t>(W) * H;
  std::vector<float> white(N), tmp(N);
  for (size_t i = 0; i < N; ++i) white[i] = static_cast<float>(gaussian(mix(key ^ (i * 0x9e3779b97f4a7c15ULL))));
  std::vector<double> k;  // taps -r..r: clamp(w/2 + 0.5 - |j|, 0, 1); they sum to w
  const int r = static_cast<int>(std::ceil(width_px / 2.0 - 0.5));
  double sq = 0;
  for (int j = -r; j <= r; ++j) {
    k.push_back(std::clamp(width_px / 2.0 + 0.5 - std::abs(j), 0.0, 1.0));
    sq += k.back() * k.back();
  }
  const double norm = 1.0 / sq;  // the 2-D filter's gain on the variance is sq^2
  // Each output sums its taps in the order j = -r..r (edges clamped); the
  // interior needs no clamp, and the column pass runs along rows.
  for (int v = 0; v < H; ++v) {
    const float* in = &white[static_cast<size_t>(v) * W];
    float* out = &tmp[static_cast<size_t>(v) * W];
    for (int u = 0; u < W; ++u) {
      double a = 0;
      if (u >= r && u < W - r) {
        for (int j = -r; j <= r; ++j) a += k[j + r] * in[u + j];
      } else {
        for (int j = -r; j <= r; ++j) a += k[j + r] * in[std::clamp(u + j, 0, W - 1)];
      }
      out[u] = static_cast<float>(a);
    }
  }
  std::vector<double> acc(W);
  for (int v = 0; v < H; ++v) {
    std::fill(acc.begin(), acc.end(), 0.0);
    for (int j = -r; j <= r; ++j) {
      const float* row = &tmp[static_cast<size_t>(std::clamp(v + j, 0, H - 1)) * W];
      const double kj = k[j + r];
      for (int u = 0; u < W; ++u) acc[u] += kj * row[u];
    }
    float* out = &white[static_cast<size_t>(v) * W];
    for (int u = 0; u < W; ++u) out[u] = static_cast<float>(acc[u] * norm);
  }
  return white;
}

double normalCdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// A field that is the same in every frame of a scene (keyed by the scene's
// seed), kept per thread for the last few scenes: the renderer's static
// fields (the holes' still share, the per-place noise level) were drawn
// again each frame, a third of the noise fields' time.  ``make`` computes
// it when it is not kept; ``param`` is any other input it depends on.
template <typename Make>
std::vector<float> staticField(uint64_t key, int W, int H, double width_px, double param, Make make) {
  using Key = std::tuple<uint64_t, int, int, uint64_t, uint64_t>;
  auto bits = [](double d) { uint64_t b; std::memcpy(&b, &d, sizeof b); return b; };
  const Key k{key, W, H, bits(width_px), bits(param)};
  thread_local std::deque<std::pair<Key, std::vector<float>>> kept;
  for (const auto& e : kept) {
    if (e.first == k) return e.second;
  }
  kept.emplace_front(k, make());
  if (kept.size() > 8) kept.pop_back();
  return kept.front().second;
}

}  // namespace

// ---------------------------------------------------------------- body shapes

BodyShape BodyShape::preset(const std::string& name) {
  BodyShape s;
  s.name = name;
  if (name == "average" || name == "model") {
    // "model": the tracker's own capsule body (render.h), the circular baseline.
  } else if (name == "short_broad") {
    s.height = 1.55; s.girth = 1.3; s.limbs = 1.15; s.arms = 0.95; s.legs = 0.92;
  } else if (name == "tall_slim") {
    s.height = 1.93; s.girth = 0.8; s.limbs = 0.85; s.arms = 1.06; s.legs = 1.06;
  } else if (name == "loose_clothes") {
    s.height = 1.68; s.girth = 1.05; s.clothing = 0.05;
  } else if (name == "dark_clothes") {
    s.height = 1.80; s.girth = 1.1; s.clothing = 0.02; s.clothes_albedo = 0.12;
  } else {
    throw std::invalid_argument("unknown body shape '" + name +
                                "' (average, short_broad, tall_slim, loose_clothes, dark_clothes, model)");
  }
  return s;
}

std::vector<std::string> BodyShape::presetNames() {
  return {"average", "short_broad", "tall_slim", "loose_clothes", "dark_clothes", "model"};
}

void BodyShape::validate() const {
  if (name == "model") {
    BodyShape plain;
    if (height != plain.height || girth != plain.girth || limbs != plain.limbs || arms != plain.arms ||
        legs != plain.legs || clothing != plain.clothing || clothes_albedo != plain.clothes_albedo) {
      throw std::invalid_argument("body=model is the fit model's own capsules on the motion as it is: "
                                  "height, girth, limbs, arms, legs, clothing and clothes_albedo do not apply");
    }
  }
  checkRange("height", height, 1.5, 1.95);
  checkRange("girth", girth, 0.6, 1.6);
  checkRange("limbs", limbs, 0.6, 1.6);
  checkRange("arms", arms, 0.8, 1.2);
  checkRange("legs", legs, 0.8, 1.2);
  checkRange("clothing", clothing, 0.0, 0.10);
  checkRange("clothes_albedo", clothes_albedo, 0.02, 1.0);
}

BodyRig::BodyRig(const Track& track, const BodyShape& shape) : track_(track), shape_(shape) {
  shape_.validate();
  // Standing height: the 90th percentile of head top over the floor; the
  // facing direction's sign: the knees bend forwards.
  std::vector<double> heights;
  double knee_votes = 0;
  for (const Joints& raw : track_.frames()) {
    Joints j = proportion(raw);
    heights.push_back(j[HEAD].y + kHeadTop - kTrackFloor);
    Vec3 up = (j[NECK] - (j[L_HIP] + j[R_HIP]) * 0.5).normalized();
    Vec3 fwd = (j[L_HIP] - j[R_HIP]).cross(up);
    for (auto leg : {std::array<int, 3>{L_HIP, L_KNEE, L_FOOT}, std::array<int, 3>{R_HIP, R_KNEE, R_FOOT}}) {
      knee_votes += fwd.dot(j[leg[1]] - (j[leg[0]] + j[leg[2]]) * 0.5);
    }
  }
  if (!heights.empty()) {
    std::sort(heights.begin(), heights.end());
    motion_height_ = heights[static_cast<size_t>(0.9 * (heights.size() - 1))];
  }
  facing_sign_ = knee_votes < 0 ? -1.0 : 1.0;
}

Joints BodyRig::proportion(const Joints& in) const {
  Joints j = in;
  const double floor_before = std::min(in[L_FOOT].y, in[R_FOOT].y);
  for (auto arm : {std::array<int, 3>{L_SHOULDER, L_ELBOW, L_HAND}, std::array<int, 3>{R_SHOULDER, R_ELBOW, R_HAND}}) {
    j[arm[1]] = in[arm[0]] + (in[arm[1]] - in[arm[0]]) * shape_.arms;
    j[arm[2]] = j[arm[1]] + (in[arm[2]] - in[arm[1]]) * shape_.arms;
  }
  for (auto leg : {std::array<int, 3>{L_HIP, L_KNEE, L_FOOT}, std::array<int, 3>{R_HIP, R_KNEE, R_FOOT}}) {
    j[leg[1]] = in[leg[0]] + (in[leg[1]] - in[leg[0]]) * shape_.legs;
    j[leg[2]] = j[leg[1]] + (in[leg[2]] - in[leg[1]]) * shape_.legs;
  }
  Vec3 lift(0, floor_before - std::min(j[L_FOOT].y, j[R_FOOT].y), 0);  // feet stay on the floor
  for (Vec3& p : j) p += lift;
  return j;
}

Joints BodyRig::pose(double t) const {
  Joints j = proportion(track_.at(t));
  if (shape_.name == "model") return j;
  const double s = shape_.height / motion_height_;
  Vec3 hips = (j[L_HIP] + j[R_HIP]) * 0.5;
  Vec3 anchor(hips.x, kTrackFloor, hips.z);  // scale about the floor under the hips
  for (Vec3& p : j) p = anchor + (p - anchor) * s;
  return j;
}

void BodyRig::capsules(const Joints& j, std::vector<Capsule>* caps, std::vector<double>* albedo) const {
  if (shape_.name == "model") {
    for (const Capsule& c : bodyCapsules(j)) { caps->push_back(c); albedo->push_back(0.6); }
    return;
  }
  const double s = shape_.height / 1.75, g = shape_.girth * s, l = shape_.limbs * s, c = shape_.clothing;
  const double cloth = shape_.clothes_albedo, skin = 0.5, hair = 0.12, shoes = 0.3;
  Vec3 hips = (j[L_HIP] + j[R_HIP]) * 0.5;
  Vec3 up = (j[HEAD] - j[NECK]).normalized();
  Vec3 fwd = ((j[L_HIP] - j[R_HIP]).cross((j[NECK] - hips).normalized()) * facing_sign_).normalized();
  auto add = [&](const Vec3& a, const Vec3& b, double r, double alb) {
    caps->push_back({a, b, r});
    albedo->push_back(alb);
  };
  // Head: dark hair on the crown and back, the face in front.
  add(j[HEAD] + up * (0.05 * s) - fwd * (0.015 * s), j[HEAD] + up * (0.05 * s) - fwd * (0.015 * s), 0.09 * s, hair);
  add(j[HEAD] + fwd * (0.03 * s) - up * (0.01 * s), j[HEAD] + fwd * (0.03 * s) - up * (0.03 * s), 0.075 * s, skin);
  add(j[NECK], j[HEAD], 0.055 * s, skin);
  // Torso: chest, sternum, belly, pelvis and flanks (wider than the fit model's torso).
  Vec3 chest_l = lerp(j[NECK], j[L_SHOULDER], 0.55) - up * (0.09 * s);
  Vec3 chest_r = lerp(j[NECK], j[R_SHOULDER], 0.55) - up * (0.09 * s);
  add(chest_l, chest_r, 0.105 * g + c, cloth);
  add(j[NECK] - up * (0.03 * s), j[TORSO], 0.10 * g + c, cloth);
  add(j[TORSO], hips, 0.115 * g + c, cloth);
  add(j[L_HIP], j[R_HIP], 0.095 * g + c, cloth);
  add(j[L_SHOULDER] - up * (0.05 * s), j[L_HIP], 0.07 * g + c, cloth);
  add(j[R_SHOULDER] - up * (0.05 * s), j[R_HIP], 0.07 * g + c, cloth);
  for (auto arm : {std::array<int, 3>{L_SHOULDER, L_ELBOW, L_HAND}, std::array<int, 3>{R_SHOULDER, R_ELBOW, R_HAND}}) {
    const Vec3 &sh = j[arm[0]], &el = j[arm[1]], &ha = j[arm[2]];
    add(sh, el, 0.046 * l + c, cloth);
    Vec3 mid = lerp(el, ha, 0.5);
    add(el, mid, 0.038 * l + 0.8 * c, cloth);
    add(mid, ha, 0.03 * l + 0.3 * c, skin);
    add(ha, ha + (ha - el).normalized() * (0.09 * s), 0.028 * s, skin);  // the hand past the wrist
  }
  for (auto leg : {std::array<int, 3>{L_HIP, L_KNEE, L_FOOT}, std::array<int, 3>{R_HIP, R_KNEE, R_FOOT}}) {
    const Vec3 &hi = j[leg[0]], &kn = j[leg[1]], &ft = j[leg[2]];
    Vec3 mid = lerp(hi, kn, 0.5);
    add(hi, mid, 0.085 * g + c, cloth);
    add(mid, kn, 0.06 * g + c, cloth);
    add(kn, ft + up * (0.06 * s), 0.047 * l + 1.3 * c, cloth);  // loose trousers flare
    add(ft + up * (0.045 * s) - fwd * (0.08 * s), ft + up * (0.04 * s) + fwd * (0.09 * s), 0.042 * s, shoes);
  }
}

// ---------------------------------------------------------------- noise

double KinectNoise::quantize(double z) const {
  double d = std::round((1.0 / z - c0) / c1);
  return 1.0 / (c1 * d + c0);
}

double KinectNoise::depthStep(double z) const {
  double d = std::round((1.0 / z - c0) / c1);
  return std::fabs(1.0 / (c1 * (d + 1) + c0) - 1.0 / (c1 * d + c0));
}

// ---------------------------------------------------------------- scenes

void SceneOptions::validate() const {
  checkRange("sensor_height", sensor_height, 0.5, 2.0);
  checkRange("tilt", tilt_deg, 0.0, 20.0);
  if (wall_gap >= 0) checkRange("wall", wall_gap, 0.1, 1.5);
  if (distance >= 0) checkRange("distance", distance, 1.0, 5.0);
  static const char* const kFurniture[] = {"none", "table", "chair", "box", "board", "door", "curtain",
                                            "coat_stand", "small_object"};
  if (std::find(std::begin(kFurniture), std::end(kFurniture), furniture) == std::end(kFurniture)) {
    throw std::invalid_argument("furniture must be none, table, chair, box, board, door, curtain, coat_stand "
                                "or small_object, not '" + furniture + "'");
  }
  checkRange("furniture_x", furniture_x, -3.0, 3.0);
  if (bystander != "none" && bystander != "walk" && bystander != "stand") {
    throw std::invalid_argument("bystander must be none, walk or stand, not '" + bystander + "'");
  }
  checkRange("bystander_offset", bystander_offset, -3.0, 3.0);
  bystander_shape.validate();
  checkRange("crowd", crowd, 0, 3);
  if (crowd_motion != "stand" && crowd_motion != "walk" && crowd_motion != "track") {
    throw std::invalid_argument("crowd_motion must be stand, walk or track, not '" + crowd_motion + "'");
  }
  if ((crowd_motion == "track") != !crowd_tracks.empty() ||
      (!crowd_tracks.empty() && static_cast<int>(crowd_tracks.size()) != crowd)) {
    throw std::invalid_argument("crowd_tracks gives each crowd member's track (crowd_motion track): " +
                                std::to_string(crowd_tracks.size()) + " tracks for a crowd of " +
                                std::to_string(crowd) + " (" + crowd_motion + ")");
  }
  checkRange("crowd_spacing", crowd_spacing, 0.3, 2.0);
}

struct Scene::Surfaces {
  struct Plane { Vec3 n; double h; uint8_t label; double albedo; };  // n.p = h, sensor frame
  struct BoxS { Box b; uint8_t label; double albedo; };               // room frame
  std::vector<Capsule> caps;          // sensor frame
  std::vector<uint8_t> cap_label;
  std::vector<double> cap_albedo;
  std::vector<Plane> planes;
  std::vector<BoxS> boxes;
};

Scene::Scene(const Track& person, const BodyShape& shape, const SceneOptions& opt, const KinectNoise& noise,
             const Track* bystander_motion, uint32_t seed)
    : person_(person, shape), opt_(opt), noise_(noise), seed_(seed) {
  opt_.validate();
  if (noise_.min_range <= 0 || noise_.max_range <= noise_.min_range) {
    throw std::invalid_argument("the sensor's range must satisfy 0 < min_range < max_range");
  }
  // The person's mean position and farthest surface over the whole motion.
  const auto& times = person.times();
  double far = 0;
  int n = 0;
  for (size_t i = 0; i < times.size(); i += 2) {
    Joints j = person_.pose(times[i]);
    Vec3 hips = (j[L_HIP] + j[R_HIP]) * 0.5;
    person_centre_ += hips;
    ++n;
    far = std::max(far, hips.z);
  }
  person_centre_ = person_centre_ * (1.0 / std::max(n, 1)) + Vec3(0, -kTrackFloor, 0);
  if (opt_.distance >= 0) shift_ = Vec3(0, 0, opt_.distance - person_centre_.z);
  person_centre_ += shift_;
  far += shift_.z;
  // The wall: wall_gap behind the person's back (hip centre + 0.15 m x girth + clothing)
  // where the motion goes farthest from the sensor.
  wall_z_ = opt_.wall_gap >= 0 ? far + 0.15 * shape.girth + shape.clothing + opt_.wall_gap : 0;

  placeFurniture();
  if (opt_.needsWalk()) {
    if (bystander_motion == nullptr) throw std::invalid_argument("a bystander needs a motion (a walk track)");
    if (opt_.bystander != "none") bystander_.emplace_back(*bystander_motion, opt_.bystander_shape);
    Vec3 c;
    int m = 0;
    for (const Joints& j : bystander_motion->frames()) { c += (j[L_HIP] + j[R_HIP]) * 0.5; ++m; }
    walk_centre_ = c * (1.0 / std::max(m, 1));
  }
  for (int k = 0; k < opt_.crowd; ++k) {
    const BodyShape crowd_shape = BodyShape::preset(kCrowdBodies[k]);
    if (opt_.crowd_motion == "track") bystander_.emplace_back(Track::load(opt_.crowd_tracks[k]), crowd_shape);
    else bystander_.emplace_back(*bystander_motion, crowd_shape);
  }
}

// The furniture: one branch per piece, each a few boxes (room frame).
void Scene::placeFurniture() {
  const double fx = person_centre_.x + opt_.furniture_x, fz = person_centre_.z;
  // Flat things stand against the wall when there is one, else beside the person.
  const double back = opt_.wall_gap >= 0 ? wall_z_ - 0.02 : fz + 0.3;
  auto box = [&](double x0, double y0, double z0, double x1, double y1, double z1) {
    furniture_.push_back({{x0, y0, z0}, {x1, y1, z1}});
  };
  auto leg = [&](double x, double z, double h) { box(x - 0.025, 0, z - 0.025, x + 0.025, h, z + 0.025); };
  const std::string& f = opt_.furniture;
  if (f == "table") {  // 0.8 x 0.6 m top, 0.74 m high
    box(fx - 0.4, 0.70, fz - 0.3, fx + 0.4, 0.74, fz + 0.3);
    for (double sx : {-0.35, 0.35}) for (double sz : {-0.25, 0.25}) leg(fx + sx, fz + sz, 0.70);
  } else if (f == "chair") {  // 0.45 m seat facing the sensor, back rest behind
    box(fx - 0.225, 0.42, fz - 0.225, fx + 0.225, 0.46, fz + 0.225);
    box(fx - 0.225, 0.46, fz + 0.19, fx + 0.225, 0.92, fz + 0.225);
    for (double sx : {-0.2, 0.2}) for (double sz : {-0.2, 0.2}) leg(fx + sx, fz + sz, 0.42);
  } else if (f == "box") {  // a moving box, 0.6 x 0.6 x 0.5 m, on the floor
    box(fx - 0.3, 0, fz - 0.25, fx + 0.3, 0.6, fz + 0.25);
  } else if (f == "board") {  // a person-sized flat panel, 0.5 x 1.8 m, 2 cm thick, on its edge
    box(fx - 0.25, 0, back - 0.12, fx + 0.25, 1.8, back - 0.10);
  } else if (f == "door") {  // a door-like slab, 0.9 x 2.0 m, 4 cm thick
    box(fx - 0.45, 0, back - 0.14, fx + 0.45, 2.0, back - 0.10);
  } else if (f == "curtain") {  // 1.2 m of curtain, 2.2 m high, in folds 0.1 m wide and 8 cm deep
    for (int k = 0; k < 12; ++k) {
      const double z = back - 0.06 - (k % 2 ? 0.08 : 0.0);
      box(fx - 0.6 + 0.1 * k, 0.02, z - 0.03, fx - 0.5 + 0.1 * k, 2.2, z);
    }
  } else if (f == "coat_stand") {  // a 1.8 m pole on a foot, a coat hanging from its hooks
    box(fx - 0.2, 0, fz - 0.2, fx + 0.2, 0.03, fz + 0.2);
    box(fx - 0.02, 0, fz - 0.02, fx + 0.02, 1.8, fz + 0.02);
    box(fx - 0.22, 0.75, fz - 0.14, fx + 0.22, 1.62, fz + 0.06);
  } else if (f == "small_object") {  // 0.3 x 0.35 x 0.25 m on a 0.45 m stool, against the wall
    box(fx - 0.15, 0.45, back - 0.27, fx + 0.15, 0.80, back - 0.02);
    box(fx - 0.17, 0.42, back - 0.29, fx + 0.17, 0.45, back);
    for (double sx : {-0.14, 0.14}) for (double sz : {-0.26, -0.03}) leg(fx + sx, back + sz, 0.42);
  }
}

Vec3 Scene::toSensor(const Vec3& room) const {
  const double a = opt_.tilt_deg * kPi / 180.0, ca = std::cos(a), sa = std::sin(a);
  const double y = room.y - opt_.sensor_height;
  return {room.x, ca * y + sa * room.z, -sa * y + ca * room.z};
}

Joints Scene::truth(double t) const {
  Joints j = person_.pose(t);
  for (Vec3& p : j) p = toSensor(p + shift_ + Vec3(0, -kTrackFloor, 0));
  return j;
}

// Extra person k: the bystander (walk: lane 0 crossing along +x; stand: at
// bystander_offset to the side), then crowd member c = 1, 2, 3: stand: in the
// walk's first pose at +s, -s, +2s (s = crowd_spacing) beside the person;
// walk: in lane bystander_offset + c s behind the person, crossing along -x,
// +x, -x (so it meets the bystander or its neighbour half way); track: on its
// own track, placed as the person's.
Joints Scene::extraPose(size_t k, double t) const {
  const bool is_bystander = opt_.bystander != "none" && k == 0;
  const int c = static_cast<int>(k) + (opt_.bystander != "none" ? 0 : 1);  // crowd number, 0: bystander
  const BodyRig& rig = bystander_[k];
  if (!is_bystander && opt_.crowd_motion == "track") {
    Joints b = rig.pose(t);
    for (Vec3& p : b) p += shift_ + Vec3(0, -kTrackFloor, 0);
    return b;
  }
  const bool walk = is_bystander ? opt_.bystander == "walk" : opt_.crowd_motion == "walk";
  Joints b = rig.pose(walk ? t : 0.0);
  // The walk's path is centred on its mean hip position; a standing person on their own hips.
  const Vec3 centre = walk ? walk_centre_ : (b[L_HIP] + b[R_HIP]) * 0.5;
  const double dir = c % 2 == 1 ? -1.0 : 1.0;  // the crowd's odd lanes walk towards -x
  const double slot = c == 0 ? opt_.bystander_offset : (c % 2 == 1 ? 1.0 : -1.0) * ((c + 1) / 2) * opt_.crowd_spacing;
  const double lane = opt_.bystander_offset + c * opt_.crowd_spacing;
  for (Vec3& p : b) {
    Vec3 r = p - Vec3(centre.x, 0, centre.z);
    if (walk) {  // the walk (towards the sensor) turned to cross the room along x
      r = Vec3(-r.z * dir, r.y, r.x * dir);
      p = r + Vec3(person_centre_.x, -kTrackFloor, person_centre_.z + lane);
    } else {
      p = r + Vec3(person_centre_.x + slot, -kTrackFloor, person_centre_.z);
    }
  }
  return b;
}

void Scene::collect(double t, Surfaces* s, SceneFrame* out) const {
  auto addBody = [&](const BodyRig& rig, const Joints& room, uint8_t label) {
    std::vector<Capsule> caps;
    std::vector<double> alb;
    rig.capsules(room, &caps, &alb);
    for (size_t i = 0; i < caps.size(); ++i) {
      s->caps.push_back({toSensor(caps[i].a), toSensor(caps[i].b), caps[i].radius});
      s->cap_label.push_back(label);
      s->cap_albedo.push_back(alb[i]);
    }
  };
  Joints room = person_.pose(t);
  for (Vec3& p : room) p += shift_ + Vec3(0, -kTrackFloor, 0);
  if (opt_.person) addBody(person_, room, LABEL_PERSON);
  for (int k = 0; k < NUM_JOINTS; ++k) out->truth[k] = toSensor(room[k]);
  const bool has_bystander = opt_.bystander != "none";
  out->has_bystander = has_bystander;
  out->crowd_truth.clear();
  for (size_t k = 0; k < bystander_.size(); ++k) {
    Joints b = extraPose(k, t);
    addBody(bystander_[k], b, LABEL_BYSTANDER);
    Joints sensor;
    for (int i = 0; i < NUM_JOINTS; ++i) sensor[i] = toSensor(b[i]);
    if (has_bystander && k == 0) out->bystander_truth = sensor;
    else out->crowd_truth.push_back(sensor);
  }
  // Planes, as n.p = h in the sensor frame.
  auto plane = [&](const Vec3& n_room, double h_room, uint8_t label, double albedo) {
    Vec3 o = toSensor(Vec3()), n = toSensor(n_room) - o;  // rotate the normal
    s->planes.push_back({n, h_room + n.dot(o), label, albedo});  // n.O = -(n_c.o)
  };
  plane({0, 1, 0}, 0.0, LABEL_FLOOR, 0.5);
  if (opt_.wall_gap >= 0) plane({0, 0, 1}, wall_z_, LABEL_WALL, 0.7);
  if (opt_.legacy_background) plane({0, 0, 1}, 4.5, LABEL_WALL, 0.7);
  for (const Box& b : furniture_) s->boxes.push_back({b, LABEL_FURNITURE, 0.45});
  if (opt_.legacy_background) s->boxes.push_back({{{-2.0, 0, 3.6}, {-1.2, 1.2, 4.0}}, LABEL_FURNITURE, 0.45});
}

double intersectCapsule(const Vec3& o, const Vec3& rd, const Capsule& cap) {
  Capsule c{cap.a - o, cap.b - o, cap.radius};
  Vec3 ba = c.b - c.a, oa = c.a * -1.0;
  double r = c.radius;
  double baba = ba.dot(ba), bard = ba.dot(rd), baoa = ba.dot(oa);
  double rdoa = rd.dot(oa), oaoa = oa.dot(oa);
  if (baba < 1e-12) {  // sphere
    double b = rdoa, cc = oaoa - r * r, h = b * b - cc;
    return h > 0 ? -b - std::sqrt(h) : -1.0;
  }
  double a = baba - bard * bard;
  double b = baba * rdoa - baoa * bard;
  double cc = baba * oaoa - baoa * baoa - r * r * baba;
  double h = b * b - a * cc;
  if (h < 0) return -1.0;
  double y = baoa;
  if (a > 1e-12) {
    double t = (-b - std::sqrt(h)) / a;
    y = baoa + t * bard;
    if (y > 0 && y < baba) return t;
  }
  Vec3 oc = (y <= 0) ? oa : c.b * -1.0;
  double b2 = rd.dot(oc), c2 = oc.dot(oc) - r * r, h2 = b2 * b2 - c2;
  return h2 > 0 ? -b2 - std::sqrt(h2) : -1.0;
}

namespace {

// One view of the scene (the camera, or the projector beside it): origin o in
// the sensor frame, same axes. Per pixel: the depth along z (inf: nothing) and
// optionally the label and the returned light (albedo x cos incidence).
struct View {
  const Camera& cam;
  Vec3 o;
  double ca, sa, sensor_h;
  std::vector<float>* z;
  std::vector<uint8_t>* label;
  std::vector<float>* shade;

  Vec3 toRoom(const Vec3& v) const { return Vec3(v.x, ca * v.y - sa * v.z, sa * v.y + ca * v.z); }
  Vec3 toView(const Vec3& r) const {
    Vec3 q = r - Vec3(0, sensor_h, 0);
    return Vec3(q.x, ca * q.y + sa * q.z, -sa * q.y + ca * q.z) - o;
  }
  void hit(size_t i, double zz, uint8_t lab, double cosi, double alb) const {
    if (zz > 0.01 && zz < (*z)[i]) {
      (*z)[i] = static_cast<float>(zz);
      if (label) (*label)[i] = lab;
      if (shade) (*shade)[i] = static_cast<float>(alb * std::fabs(cosi));
    }
  }
};

template <typename Planes>
void castPlanes(const Planes& planes, const View& view) {
  const Camera& cam = view.cam;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      Vec3 d = cam.ray(u, v);
      const double dn = d.norm();
      for (const auto& p : planes) {
        double den = p.n.dot(d);
        if (std::fabs(den) < 1e-9) continue;
        view.hit(static_cast<size_t>(v) * cam.width + u, (p.h - p.n.dot(view.o)) / den, p.label, den / dn, p.albedo);
      }
    }
  }
}

// The pixel box a room-frame box covers in the view (the whole image when a corner is behind it).
void boxPixels(const Vec3& lo, const Vec3& hi, const View& view, int* u0, int* u1, int* v0, int* v1) {
  const Camera& cam = view.cam;
  *u0 = 0; *u1 = cam.width - 1; *v0 = 0; *v1 = cam.height - 1;
  double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
  for (int k = 0; k < 8; ++k) {
    Vec3 w = view.toView(Vec3((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z));
    if (w.z < 0.05) return;
    double pu, pv;
    cam.project(w, &pu, &pv);
    umin = std::min(umin, pu); umax = std::max(umax, pu);
    vmin = std::min(vmin, pv); vmax = std::max(vmax, pv);
  }
  *u0 = std::max(0, static_cast<int>(std::floor(umin))); *u1 = std::min(cam.width - 1, static_cast<int>(std::ceil(umax)));
  *v0 = std::max(0, static_cast<int>(std::floor(vmin))); *v1 = std::min(cam.height - 1, static_cast<int>(std::ceil(vmax)));
}

template <typename Boxes>
void castBoxes(const Boxes& boxes, const View& view) {
  const Vec3 o_room = view.toRoom(view.o) + Vec3(0, view.sensor_h, 0);
  const double ov[3] = {o_room.x, o_room.y, o_room.z};
  for (const auto& bx : boxes) {
    int u0, u1, v0, v1;
    boxPixels(bx.b.lo, bx.b.hi, view, &u0, &u1, &v0, &v1);
    const double lo[3] = {bx.b.lo.x, bx.b.lo.y, bx.b.lo.z}, hi[3] = {bx.b.hi.x, bx.b.hi.y, bx.b.hi.z};
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {  // slab test in the room frame
        Vec3 d = view.cam.ray(u, v), dr = view.toRoom(d);
        const double dv[3] = {dr.x, dr.y, dr.z};
        double t0 = -1e30, t1 = 1e30;
        int axis = 0;
        bool miss = false;
        for (int k = 0; k < 3 && !miss; ++k) {
          if (std::fabs(dv[k]) < 1e-12) { miss = ov[k] < lo[k] || ov[k] > hi[k]; continue; }
          double a = (lo[k] - ov[k]) / dv[k], b = (hi[k] - ov[k]) / dv[k];
          if (a > b) std::swap(a, b);
          if (a > t0) { t0 = a; axis = k; }
          t1 = std::min(t1, b);
          miss = t0 > t1;
        }
        if (!miss && t0 > 0) view.hit(static_cast<size_t>(v) * view.cam.width + u, t0, bx.label, dv[axis] / d.norm(), bx.albedo);
      }
    }
  }
}

template <typename S>
void castCapsules(const S& s, const View& view) {
  const Camera& cam = view.cam;
  for (size_t c = 0; c < s.caps.size(); ++c) {
    const Capsule& cap = s.caps[c];
    int u0, u1, v0, v1;
    if (!capsulePixelBox(cap, view.o, cam, &u0, &u1, &v0, &v1)) continue;
    Vec3 axis = cap.b - cap.a;
    const double axis2 = axis.dot(axis);
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        Vec3 d = cam.ray(u, v);
        double n = d.norm();
        Vec3 rd = d * (1.0 / n);
        double t = intersectCapsule(view.o, rd, cap);
        if (t <= 0) continue;
        const size_t i = static_cast<size_t>(v) * cam.width + u;
        double zz = t / n;
        if (!(zz < (*view.z)[i])) continue;
        double cosi = 1.0;
        if (view.shade) {  // the surface normal: from the axis to the hit point
          Vec3 p = view.o + rd * t;
          double w = axis2 > 1e-12 ? std::clamp((p - cap.a).dot(axis) / axis2, 0.0, 1.0) : 0.0;
          cosi = (p - (cap.a + axis * w)).normalized().dot(rd);
        }
        view.hit(i, zz, s.cap_label[c], cosi, s.cap_albedo[c]);
      }
    }
  }
}

// Ray casting of all the surfaces from view origin o.
template <typename S>
void castView(const S& s, const Camera& cam, const Vec3& o, double tilt_rad, double sensor_h,
              std::vector<float>* z, std::vector<uint8_t>* label, std::vector<float>* shade) {
  const size_t N = static_cast<size_t>(cam.width) * cam.height;
  z->assign(N, std::numeric_limits<float>::infinity());
  if (label) label->assign(N, LABEL_NONE);
  if (shade) shade->assign(N, 0.f);
  const View view{cam, o, std::cos(tilt_rad), std::sin(tilt_rad), sensor_h, z, label, shade};
  castPlanes(s.planes, view);
  castBoxes(s.boxes, view);
  castCapsules(s, view);
}

// Where the projector's pattern does not reach: the point at (u, v, z) is hidden from
// the projector, shifted along x only, by something nearer on the same row.
struct Shadow {
  bool on = false;
  const std::vector<float>* zp = nullptr;  // depth seen from the projector
  double shift_px_m = 0;                   // pixels of shift at 1 m
  int W = 0;
  bool operator()(int u, int v, double zz) const {
    if (!on) return false;
    int iu = static_cast<int>(std::lround(u - shift_px_m / zz));
    return iu >= 0 && iu < W && (*zp)[static_cast<size_t>(v) * W + iu] < zz - (0.03 + 0.01 * zz);
  }
};

// Depth edges: what reads (in range, lit by the projector) next to what does not, or a
// jump of more than 5 cm + 3 % between neighbours within r pixels.
std::vector<uint8_t> depthEdges(const std::vector<float>& z, int W, int H, int r, const KinectNoise& n,
                                const Shadow& shadowed) {
  const size_t N = z.size();
  std::vector<float> ze(N, std::numeric_limits<float>::infinity());
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      double zz = z[i];
      if (!std::isfinite(zz) || zz < n.min_range || zz > n.max_range || shadowed(u, v, zz)) continue;
      ze[i] = static_cast<float>(zz);
    }
  }
  std::vector<uint8_t> edge(N, 0);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      if (!std::isfinite(ze[i])) continue;
      const float thr = static_cast<float>(0.05 + 0.03 * ze[i]);
      bool e = false;
      for (int vv = std::max(0, v - r); vv <= std::min(H - 1, v + r) && !e; ++vv) {
        for (int uu = std::max(0, u - r); uu <= std::min(W - 1, u + r); ++uu) {
          float o = ze[static_cast<size_t>(vv) * W + uu];
          if (!(std::fabs(o - ze[i]) <= thr)) { e = true; break; }
        }
      }
      edge[i] = e;
    }
  }
  return edge;
}

// The real sensor's structure (speckle) for one frame: the disparity error correlated
// in blobs, a whole-frame offset, flicker at depth edges and shadow borders, holes in
// patches. Empty fields are off.
struct Speckle {
  std::vector<float> fine, coarse, edge_field, hole_field, level;
  std::vector<uint8_t> edge;
  double offset = 0;
};

// The frame's offset: the value drawn at the latest jump (frame 0 always draws).
double frameOffset(const KinectNoise& n, uint32_t seed, uint64_t frame_index) {
  const uint64_t okey = mix((static_cast<uint64_t>(seed) << 32) ^ 0x27d4eb2fULL);
  uint64_t k = frame_index;
  while (k > 0 && frame_index - k < 3000 &&
         (mix(okey ^ (k * 0x9e3779b97f4a7c15ULL)) >> 11) * (1.0 / 9007199254740992.0) >= n.frame_offset_jump) {
    --k;
  }
  return n.frame_offset_sigma * gaussian(mix(okey + 0x165667b19e3779f9ULL + k));
}

Speckle makeSpeckle(const KinectNoise& n, uint32_t seed, uint64_t key0, uint64_t frame_index,
                    const std::vector<float>& z, int W, int H, const Shadow& shadowed) {
  Speckle sp;
  const size_t N = z.size();
  const double px_scale = W / 640.0;  // the model's windows are in 640x480 pixels
  auto stream = [&](uint64_t k) { return mix(key0 + k * 0x632be59bd9b4e019ULL); };
  if (n.fine_share > 0) sp.fine = correlatedField(stream(1), W, H, n.fine_px * px_scale);
  if (n.coarse_share > 0) sp.coarse = correlatedField(stream(2), W, H, n.coarse_px * px_scale);
  if (n.holes) {
    const uint64_t static_key = mix((static_cast<uint64_t>(seed) << 32) ^ 0x5bd1e995ULL);
    const std::vector<float> still = staticField(static_key, W, H, n.hole_px * px_scale, 0.0, [&] {
      return correlatedField(static_key, W, H, n.hole_px * px_scale);
    });
    sp.hole_field = correlatedField(stream(3), W, H, n.hole_px * px_scale);
    const double a = std::sqrt(n.hole_static_share), b = std::sqrt(1.0 - n.hole_static_share);
    for (size_t i = 0; i < N; ++i) sp.hole_field[i] = static_cast<float>(a * still[i] + b * sp.hole_field[i]);
  }
  if (n.sigma_spread > 0) {  // a static per-place noise level, lognormal
    const uint64_t static_key = mix((static_cast<uint64_t>(seed) << 32) ^ 0x85ebca6bULL);
    const double t = n.sigma_spread;
    sp.level = staticField(static_key, W, H, n.fine_px * px_scale, t, [&] {
      std::vector<float> level = correlatedField(static_key, W, H, n.fine_px * px_scale);
      for (float& x : level) x = static_cast<float>(std::exp(t * x - 0.5 * t * t));
      return level;
    });
  }
  if (n.frame_offset_sigma > 0) sp.offset = frameOffset(n, seed, frame_index);
  if (n.edge_drop > 0 && n.edge_px > 0) {
    const int r = std::max(1, static_cast<int>(std::lround(n.edge_px * px_scale)));
    sp.edge = depthEdges(z, W, H, r, n, shadowed);
    sp.edge_field = correlatedField(stream(4), W, H, n.fine_px * px_scale);
  }
  return sp;
}

}  // namespace

void Scene::render(double t, uint64_t frame_index, const Camera& cam, SceneFrame* out) const {
  Surfaces s;
  collect(t, &s, out);
  const double tilt = opt_.tilt_deg * kPi / 180.0;
  std::vector<float> z, shade, zp;
  castView(s, cam, Vec3(), tilt, opt_.sensor_height, &z, &out->label, &shade);
  const int W = cam.width, H = cam.height;
  Shadow shadowed;
  shadowed.on = noise_.enabled && noise_.shadow && noise_.baseline > 0;
  if (shadowed.on) {
    const Vec3 proj(noise_.baseline * (noise_.projector_x < 0 ? -1.0 : 1.0), 0, 0);
    castView(s, cam, proj, tilt, opt_.sensor_height, &zp, nullptr, nullptr);
    shadowed.zp = &zp;
    shadowed.shift_px_m = proj.x * W / cam.xzFactor();
    shadowed.W = W;
  }
  const size_t N = z.size();
  out->depth_mm.assign(N, 0);
  const uint64_t key0 = mix((static_cast<uint64_t>(seed_) << 32) ^ frame_index);
  const bool speckle = noise_.enabled && noise_.speckle;
  const Speckle sp = speckle ? makeSpeckle(noise_, seed_, key0, frame_index, z, W, H, shadowed) : Speckle();
  const double iid_share = std::max(0.0, 1.0 - (sp.fine.empty() ? 0.0 : noise_.fine_share) -
                                             (sp.coarse.empty() ? 0.0 : noise_.coarse_share));
  const double s_iid = std::sqrt(iid_share), s_fine = std::sqrt(noise_.fine_share),
               s_coarse = std::sqrt(noise_.coarse_share);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      double zz = z[i];
      if (!std::isfinite(zz)) { out->label[i] = LABEL_NONE; continue; }
      if (!noise_.enabled) {
        if (zz >= 0.4 && zz < 8.0) out->depth_mm[i] = static_cast<uint16_t>(std::lround(zz * 1000.0));
        continue;
      }
      if (zz < noise_.min_range || zz > noise_.max_range) continue;
      // One hash per pixel: its low 32 bits decide a hole, its top 12 the disparity error.
      const uint64_t hash = mix(key0 ^ (i * 0x9e3779b97f4a7c15ULL));
      if (noise_.holes) {
        // Returned infrared: albedo x cos(incidence) / (z / 2 m)^2; too little and
        // the dot pattern is lost (dark hair, black clothes, grazing surfaces, far floor).
        double signal = shade[i] / ((zz / 2.0) * (zz / 2.0));
        double p_drop = std::clamp((0.045 - signal) / 0.03, 0.0, 1.0);
        // Speckle: patches (a correlated field below the drop quantile), else per pixel.
        if (p_drop > 0) {
          double q = sp.hole_field.empty() ? (hash & 0xffffffffULL) * (1.0 / 4294967296.0) : normalCdf(sp.hole_field[i]);
          if (q < p_drop) continue;
        }
      }
      // The point seen here, from the projector: hidden behind something nearer = no pattern.
      if (shadowed(u, v, zz)) continue;
      // Edges and shadow borders flicker: the correlation window straddles two depths.
      if (!sp.edge.empty() && sp.edge[i] && normalCdf(sp.edge_field[i]) < noise_.edge_drop) continue;
      double err = gaussian(hash);
      if (speckle) {
        err = s_iid * err + (sp.fine.empty() ? 0.0 : s_fine * sp.fine[i]) +
              (sp.coarse.empty() ? 0.0 : s_coarse * sp.coarse[i]);
        if (!sp.level.empty()) err *= sp.level[i];
      }
      double d = std::round((1.0 / zz - noise_.c0) / noise_.c1 + noise_.disparity_sigma * err + sp.offset);
      if (d < 0 || d > 2046) continue;
      double zq = 1.0 / (noise_.c1 * d + noise_.c0);
      if (zq < noise_.min_range || zq > noise_.max_range) continue;
      out->depth_mm[i] = static_cast<uint16_t>(std::lround(zq * 1000.0));
    }
  }
}

}  // namespace hri_sync

namespace hri_sync {

namespace {

double number(const std::string& key, const std::string& value) {
  try {
    size_t pos = 0;
    double v = std::stod(value, &pos);
    if (pos == value.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw std::invalid_argument("bad value '" + value + "' for '" + key + "' (a number)");
}

bool flag(const std::string& key, const std::string& value) {
  if (value == "1" || value == "true") return true;
  if (value == "0" || value == "false") return false;
  throw std::invalid_argument("bad value '" + value + "' for '" + key + "' (0 or 1)");
}

}  // namespace

const char* sceneKeys() {
  return "body, height, girth, limbs, arms, legs, clothing, clothes_albedo, person, wall, distance, furniture, "
         "furniture_x, "
         "bystander, bystander_offset, bystander_body, bystander_track, crowd, crowd_motion, crowd_spacing, crowd_tracks, "
         "sensor_height, tilt, "
         "noise=kinect1|kinect1_iid, "
         "shadow, holes, baseline, projector, min_range, max_range, seed";
}

SceneSpec parseSceneQuery(const std::string& query) {
  SceneSpec spec;
  size_t pos = 0;
  while (pos < query.size()) {
    size_t amp = query.find('&', pos);
    std::string item = query.substr(pos, amp == std::string::npos ? std::string::npos : amp - pos);
    pos = amp == std::string::npos ? query.size() : amp + 1;
    if (item.empty()) continue;
    size_t eq = item.find('=');
    if (eq == std::string::npos || !applySceneKey(item.substr(0, eq), item.substr(eq + 1), &spec)) {
      throw std::invalid_argument("'" + item + "' is not a scene key=value (" + sceneKeys() + ")");
    }
  }
  return spec;
}

bool applySceneKey(const std::string& key, const std::string& value, SceneSpec* spec) {
  BodyShape& b = spec->body;
  SceneOptions& s = spec->scene;
  KinectNoise& n = spec->noise;
  if (key == "body") {
    b = BodyShape::preset(value);  // throws on an unknown name; set body= before height= etc.
  } else if (key == "height") { b.height = number(key, value);
  } else if (key == "girth") { b.girth = number(key, value);
  } else if (key == "limbs") { b.limbs = number(key, value);
  } else if (key == "arms") { b.arms = number(key, value);
  } else if (key == "legs") { b.legs = number(key, value);
  } else if (key == "clothing") { b.clothing = number(key, value);
  } else if (key == "clothes_albedo") { b.clothes_albedo = number(key, value);
  } else if (key == "wall") {
    s.wall_gap = value == "none" ? -1.0 : number(key, value);
    if (s.wall_gap >= 0) checkRange("wall", s.wall_gap, 0.1, 1.5);
  } else if (key == "distance") { s.distance = number(key, value);
  } else if (key == "person") { s.person = flag(key, value);
  } else if (key == "furniture") { s.furniture = value;
  } else if (key == "furniture_x") { s.furniture_x = number(key, value);
  } else if (key == "bystander") { s.bystander = value;
  } else if (key == "bystander_offset") { s.bystander_offset = number(key, value);
  } else if (key == "bystander_body") { s.bystander_shape = BodyShape::preset(value);
  } else if (key == "bystander_track") { spec->bystander_track = value;
  } else if (key == "crowd") {
    const double v = number(key, value);
    if (v < 0 || v > 3 || v != std::floor(v)) throw std::invalid_argument("crowd must be 0, 1, 2 or 3, not " + value);
    s.crowd = static_cast<int>(v);
  } else if (key == "crowd_motion") { s.crowd_motion = value;
  } else if (key == "crowd_tracks") {  // a, b, c: the crowd, each on its own track
    s.crowd_tracks.clear();
    for (size_t from = 0; from <= value.size();) {
      const size_t comma = std::min(value.find(',', from), value.size());
      s.crowd_tracks.push_back(value.substr(from, comma - from));
      from = comma + 1;
    }
    if (s.crowd_tracks.size() > 3 || value.empty()) {
      throw std::invalid_argument("crowd_tracks takes 1-3 comma-separated track files, not '" + value + "'");
    }
    s.crowd = static_cast<int>(s.crowd_tracks.size());
    s.crowd_motion = "track";
  } else if (key == "crowd_spacing") { s.crowd_spacing = number(key, value);
  } else if (key == "sensor_height") { s.sensor_height = number(key, value);
  } else if (key == "tilt") { s.tilt_deg = number(key, value);
  } else if (key == "noise") {
    if (value == "kinect1") {
      n.enabled = true;
      n.speckle = true;
    } else if (value == "kinect1_iid") {  // the earlier model: independent per-pixel error and holes
      n.enabled = true;
      n.speckle = false;
      n.disparity_sigma = 0.5;
    } else {
      return false;  // a number: the legacy renderer's Gaussian sigma
    }
  } else if (key == "shadow") { n.shadow = flag(key, value);
  } else if (key == "holes") { n.holes = flag(key, value);
  } else if (key == "baseline") { n.baseline = number(key, value); checkRange("baseline", n.baseline, 0.0, 0.3);
  } else if (key == "projector") {
    if (value == "+x") n.projector_x = 1.0;
    else if (value == "-x") n.projector_x = -1.0;
    else throw std::invalid_argument("bad value '" + value + "' for 'projector' (+x or -x)");
  } else if (key == "min_range") { n.min_range = number(key, value); checkRange("min_range", n.min_range, 0.3, 2.0);
  } else if (key == "max_range") { n.max_range = number(key, value); checkRange("max_range", n.max_range, 1.0, 10.0);
  } else if (key == "seed") {
    double v = number(key, value);
    if (v < 0 || v > 4294967295.0 || v != std::floor(v)) throw std::invalid_argument("seed must be an integer >= 0");
    spec->seed = static_cast<uint32_t>(v);
  } else {
    return false;
  }
  spec->used = true;
  return true;
}

}  // namespace hri_sync
