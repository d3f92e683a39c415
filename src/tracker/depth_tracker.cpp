#include "hri_sync/depth_tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <random>

#include "hri_sync/pose_fit.h"

namespace hri_sync {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// DepthSteadier: cells within 3 disparity steps (2.85e-3 1/m each) of their
// reference measure the shift; at least this many of them; the reference's rate.
constexpr double kKinectDepthStep = 2.85e-3;  // a Kinect v1's depth step at z: this times z^2 (m)
constexpr double kSteadyBand = 3 * kKinectDepthStep;
constexpr size_t kSteadyCells = 200;
// A body cut by the image's edge or the sensor's range over more than this is
// only partly seen: wider than a hand or a foot (m).
constexpr double kCutWidth = 0.20;
constexpr double kSteadyRate = 0.1;
constexpr double kSteadyMeanRate = 1.0 / 900;  // the shifts' mean over about 30 s
constexpr int kSearchFitsPerFrame = 2;  // pose fits of the bone-length search per frame
constexpr int kRefitEvery = 3;          // frames between two kept for the second search
constexpr double kHeadAxis = 0.2;         // m: a head candidate's horizontal reach from the neck
constexpr double kHeadBelowTop = 0.15;    // m a head may sit below the axis's top while calibrating
constexpr double kBelowAxisTopCost = 4.0; // labelling cost per m below that
constexpr size_t kRefitFrames = 8;      // frames the second search fits
constexpr double kMaxReach = 1.25;      // a limb's reach, at most, over its proportions' (scaled up to 1.2)
constexpr double kModelStepPerFrame = 0.003;  // a length's largest relative change per frame
constexpr int kSeenPoints = 5;  // depth points a fitted joint needs to count as seen
constexpr double kStrongBend = 0.15;  // m each knee must bend for the knees to say the facing
constexpr double kBendsAgree = 0.5;   // cosine of the largest angle between the two knees' bends
constexpr int kFacingVotes = 2;       // frames in a row the knees say the fit faces the wrong way
constexpr double kStackedBehind = 0.2;  // m an upper part may lie behind the part it rests on (a taller
                                        // person right behind shows above the head)

// Neighbouring points belong to one object when their depths differ by less than this.
double maxJump(double z) { return 0.05 + 0.02 * z; }
// Geodesic paths cross only smaller steps, so a hand held in front of the body stays apart.
double maxStep(double z) { return 0.05 + 0.02 * z; }

Vec3 horizontal(const Vec3& v, const Vec3& up) { return v - up * v.dot(up); }

// A surface point pushed back along its viewing ray, towards the bone inside.
Vec3 behind(const Vec3& p, double r) { return p + p.normalized() * r; }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Calls f(j) for each grid neighbour j of cell i: the 8-neighbourhood, or with
// n = 4 the 4-neighbourhood (its first four).
template <typename F>
void forNeighbours(const PointGrid& g, int i, F f, int n = 8) {
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const int x = i % g.width, y = i / g.width;
  for (int k = 0; k < n; ++k) {
    const int nx = x + kDx[k], ny = y + kDy[k];
    if (nx >= 0 && ny >= 0 && nx < g.width && ny < g.height) f(ny * g.width + nx);
  }
}

// Dijkstra over the user's cells from the cells already holding a finite distance in queue.
void relax(const PointGrid& g, const std::vector<uint8_t>& mask, std::vector<float>* dist,
           std::vector<int>* parent,
           std::priority_queue<std::pair<float, int>, std::vector<std::pair<float, int>>,
                               std::greater<std::pair<float, int>>>* q) {
  while (!q->empty()) {
    auto [d, i] = q->top();
    q->pop();
    if (d > (*dist)[i]) continue;
    const Vec3& p = g.points[i];
    forNeighbours(g, i, [&](int j) {
      if (!mask[j]) return;
      const Vec3& r = g.points[j];
      if (std::fabs(r.z - p.z) > maxStep(p.z)) return;
      float nd = d + static_cast<float>((r - p).norm());
      if (nd < (*dist)[j]) {
        (*dist)[j] = nd;
        if (parent) (*parent)[j] = i;
        q->push({nd, j});
      }
    });
  }
}

// Smallest standard deviation of a point set across any plane (0 for a flat object).
double thickness(const PointGrid& g, const std::vector<int>& cells, const Vec3& mean) {
  double c[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (int i : cells) {
    Vec3 d = g.points[i] - mean;
    double v[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) c[a][b] += v[a] * v[b];
  }
  for (auto& row : c) for (double& x : row) x /= cells.size();
  // Smallest eigenvalue of the symmetric 3x3 covariance (trigonometric method).
  double p1 = c[0][1] * c[0][1] + c[0][2] * c[0][2] + c[1][2] * c[1][2];
  double q = (c[0][0] + c[1][1] + c[2][2]) / 3;
  double p2 = (c[0][0] - q) * (c[0][0] - q) + (c[1][1] - q) * (c[1][1] - q) + (c[2][2] - q) * (c[2][2] - q) + 2 * p1;
  double pp = std::sqrt(p2 / 6);
  if (pp < 1e-12) return std::sqrt(std::max(0.0, q));
  double b[3][3];
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k) b[a][k] = (c[a][k] - (a == k ? q : 0)) / pp;
  double r = (b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
              b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0])) / 2;
  double phi = std::acos(std::clamp(r, -1.0, 1.0)) / 3;
  double smallest = q + 2 * pp * std::cos(phi + 2 * M_PI / 3);
  return std::sqrt(std::max(0.0, smallest));
}

// The point of a limb's path (tip first) where both bones fit between root and end.
Vec3 midJoint(const std::vector<Vec3>& path, const Vec3& root, const Vec3& end, double upper,
              double lower, double* misfit) {
  double best = 1e18;
  Vec3 mid = (root + end) * 0.5;
  for (const Vec3& p : path) {
    double c = std::fabs((p - end).norm() - lower) + std::fabs((p - root).norm() - upper);
    if (c < best) { best = c; mid = p; }
  }
  if (misfit) *misfit = best;
  return mid;
}

// The middle joint of a two-bone limb from its ends, bent towards pole.
Vec3 twoBone(const Vec3& root, const Vec3& end, double upper, double lower, const Vec3& pole) {
  Vec3 axis = end - root;
  double d = std::clamp(axis.norm(), std::fabs(upper - lower) + 1e-3, upper + lower - 1e-3);
  Vec3 u = axis.norm() > 1e-6 ? axis.normalized() : Vec3(0, -1, 0);
  double along = (upper * upper - lower * lower + d * d) / (2 * d);
  double h = std::sqrt(std::max(0.0, upper * upper - along * along));
  Vec3 side = pole - u * pole.dot(u);
  if (side.norm() < 1e-6) side = Vec3(0, -1, 0) - u * (-u.y);
  return root + u * along + side.normalized() * h;
}

// The unit normal n of the plane through three random candidate points, one of
// them a (RANSAC's sample); false when they are on a line.
bool randomPlane(const PointGrid& g, const std::vector<int>& cand, std::mt19937* rng, Vec3* n, Vec3* a) {
  std::uniform_int_distribution<size_t> pick(0, cand.size() - 1);
  const Vec3 &p = g.points[cand[pick(*rng)]], &q = g.points[cand[pick(*rng)]], &r = g.points[cand[pick(*rng)]];
  const Vec3 m = (q - p).cross(r - p);
  if (m.norm() < 1e-9) return false;
  *n = m.normalized();
  *a = p;
  return true;
}

// The share of the grid cells within the image box of a plane's points (the
// candidates not in rest) that show something behind it (more than two margins)
// or no return: a wall hides what is behind it; people standing side by side
// at one depth, whose fronts can make a plane as large, do not.
double seeThrough(const PointGrid& g, const Plane& plane, const std::vector<int>& cand, const std::vector<int>& rest) {
  std::vector<uint8_t> off(g.width * g.height, 0);
  for (int i : rest) off[i] = 1;
  int gx0 = g.width, gx1 = -1, gy0 = g.height, gy1 = -1;
  for (int i : cand) {
    if (off[i]) continue;
    gx0 = std::min(gx0, i % g.width); gx1 = std::max(gx1, i % g.width);
    gy0 = std::min(gy0, i / g.width); gy1 = std::max(gy1, i / g.width);
  }
  int cells = 0, through = 0;
  for (int y = gy0; y <= gy1; ++y) {
    for (int x = gx0; x <= gx1; ++x) {
      const int i = y * g.width + x;
      ++cells;
      through += !g.ok(i) || plane.height(g.points[i]) < -2 * planeMargin(g.points[i].z);
    }
  }
  return cells ? double(through) / cells : 1.0;
}

// The share of a part's lowest cells (one per image column) under which the
// view is open: the cell two rows below shows the floor or something farther
// away. Below the image's bottom, no reading, or something nearer (an
// occluder) hides what is under it.
double openBelow(const PointGrid& g, const Blob& p) {
  std::vector<int> lowest(g.width, -1);
  for (int i : p.cells) {
    const int x = i % g.width;
    if (lowest[x] < 0 || i / g.width > lowest[x] / g.width) lowest[x] = i;
  }
  int columns = 0, open = 0;
  for (int i : lowest) {
    if (i < 0) continue;
    ++columns;
    const int below = i + 2 * g.width;
    if (below >= g.width * g.height || !g.ok(below)) continue;
    open += g.points[below].z > g.points[i].z - maxJump(g.points[i].z);
  }
  return columns ? double(open) / columns : 0.0;
}

}  // namespace

PointGrid makeGrid(const uint16_t* depth_mm, const Camera& cam, int step) {
  PointGrid g;
  g.step = std::max(1, step);
  g.width = cam.width / g.step;
  g.height = cam.height / g.step;
  g.points.resize(static_cast<size_t>(g.width) * g.height);
  g.valid.assign(g.points.size(), 0);
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) {
      int u = x * g.step + g.step / 2, v = y * g.step + g.step / 2;
      uint16_t d = depth_mm[v * cam.width + u];
      if (d == 0) continue;
      int i = y * g.width + x;
      g.points[i] = cam.toWorld(u, v, d * 0.001);
      g.valid[i] = 1;
    }
  }
  return g;
}

namespace {

// The least-squares plane y = a x + b z + c through the points within 2 cm of
// a RANSAC plane (three points tilt a narrow strip of floor by degrees).
Plane refineFloor(const PointGrid& g, const std::vector<int>& cand, const Plane& p) {
  double m[3][3] = {}, r[3] = {};
  for (int i : cand) {
    const Vec3& q = g.points[i];
    if (std::fabs(p.height(q)) >= 0.02) continue;
    const double v[3] = {q.x, q.z, 1.0};
    for (int a = 0; a < 3; ++a) {
      r[a] += v[a] * q.y;
      for (int b = 0; b < 3; ++b) m[a][b] += v[a] * v[b];
    }
  }
  auto det = [](const double (&k)[3][3]) {
    return k[0][0] * (k[1][1] * k[2][2] - k[1][2] * k[2][1]) - k[0][1] * (k[1][0] * k[2][2] - k[1][2] * k[2][0]) +
           k[0][2] * (k[1][0] * k[2][1] - k[1][1] * k[2][0]);
  };
  const double d0 = det(m);
  if (std::fabs(d0) < 1e-12) return p;
  double sol[3];
  for (int c = 0; c < 3; ++c) {  // Cramer's rule
    double k[3][3];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) k[a][b] = b == c ? r[a] : m[a][b];
    sol[c] = det(k) / d0;
  }
  Plane out = p;
  const Vec3 n(-sol[0], 1.0, -sol[1]);
  out.n = n.normalized();
  out.d = -sol[2] / n.norm();
  return out;
}

}  // namespace

Plane fitFloor(const PointGrid& g, uint32_t seed) {
  std::vector<int> cand;  // the lower half of the image holds the floor
  for (int y = g.height / 2; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x)
      if (g.ok(y * g.width + x)) cand.push_back(y * g.width + x);
  Plane best;
  if (cand.size() < 50) return best;
  std::mt19937 rng(seed);
  size_t best_inliers = 0;
  for (int it = 0; it < 150; ++it) {
    Vec3 n, a;
    if (!randomPlane(g, cand, &rng, &n, &a)) continue;
    if (n.y < 0) n = n * -1.0;
    if (n.y < 0.866) continue;  // within 30 degrees of vertical
    double d = -n.dot(a);
    size_t inl = 0;
    for (int i : cand) inl += std::fabs(n.dot(g.points[i]) + d) < 0.02;
    if (inl > best_inliers) {
      best_inliers = inl;
      best.n = n;
      best.d = d;
    }
  }
  if (best_inliers >= 3) best = refineFloor(g, cand, best);
  // The floor lies below the sensor and is a large share of the lower half, or
  // (a narrow strip before a wall near the person) a smaller one with nothing
  // seen below it, which a table top or a seat would have.
  size_t below = 0;
  for (int i : cand) below += best.n.dot(g.points[i]) + best.d < -0.05;
  const bool large = best_inliers > cand.size() / 5;
  const bool strip = best_inliers > cand.size() / 25 && below < best_inliers / 50;
  best.found = (large || strip) && best.d > 0.2;
  return best;
}

double planeMargin(double z) { return 0.03 + 3.6e-3 * z * z; }

std::vector<Plane> fitWalls(const PointGrid& g, const Plane& floor, uint32_t seed, int max_planes) {
  const Vec3 up = floor.found ? floor.n : Vec3(0, 1, 0);
  std::vector<int> cand;
  for (int i = 0; i < g.width * g.height; ++i)
    if (g.ok(i) && !(floor.found && floor.height(g.points[i]) < 0.05)) cand.push_back(i);
  const double cell = g.step * Camera().xzFactor() / (g.width * g.step);  // cell size at 1 m, per m of depth
  std::vector<Plane> walls;
  std::mt19937 rng(seed);
  for (int k = 0; k < max_planes && cand.size() >= 100; ++k) {
    Plane best;
    double best_area = 0;
    for (int it = 0; it < 120; ++it) {
      Vec3 n, a;
      if (!randomPlane(g, cand, &rng, &n, &a)) continue;
      if (std::fabs(n.dot(up)) > 0.5) continue;  // within 30 degrees of vertical
      if (n.dot(a) > 0) n = n * -1.0;            // facing the sensor
      const double d = -n.dot(a);
      double area = 0;
      for (size_t s = 0; s < cand.size(); s += 4) {
        const Vec3& p = g.points[cand[s]];
        if (std::fabs(n.dot(p) + d) < planeMargin(p.z)) area += 4 * (p.z * cell) * (p.z * cell);
      }
      if (area > best_area) { best_area = area; best.n = n; best.d = d; }
    }
    if (best_area < 1.5) break;
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    const Vec3 across = up.cross(best.n).normalized();
    std::vector<int> rest;
    for (int i : cand) {
      const Vec3& p = g.points[i];
      if (std::fabs(best.height(p)) >= planeMargin(p.z)) { rest.push_back(i); continue; }
      x0 = std::min(x0, p.dot(across)); x1 = std::max(x1, p.dot(across));
      y0 = std::min(y0, p.dot(up)); y1 = std::max(y1, p.dot(up));
    }
    if (x1 - x0 < 1.0 || y1 - y0 < 1.0) break;  // a large plane no person could be
    if (seeThrough(g, best, cand, rest) > 0.25) break;  // people side by side, not a wall
    best.found = true;
    walls.push_back(best);
    cand.swap(rest);
  }
  return walls;
}

namespace {

// The offset of the points within band of a wall from it (m), trimmed to one
// margin about their median; false when fewer than 50 cells show it.
bool wallOffset(const PointGrid& g, const Plane& floor, const Plane& wall, double band, double* offset) {
  std::vector<double> h;
  std::vector<double> margin;
  for (int i = 0; i < g.width * g.height; ++i) {
    if (!g.ok(i) || (floor.found && floor.height(g.points[i]) < 0.05)) continue;
    const double m = planeMargin(g.points[i].z), d = wall.height(g.points[i]);
    if (std::fabs(d) < band * m) { h.push_back(d); margin.push_back(m); }
  }
  if (h.size() < 50) return false;
  const double mid = median(h);
  double sum = 0;
  int n = 0;
  for (size_t k = 0; k < h.size(); ++k) {
    if (std::fabs(h[k] - mid) < margin[k]) { sum += h[k]; ++n; }
  }
  *offset = n ? sum / n : mid;
  return true;
}

}  // namespace

Plane followWall(const PointGrid& g, const Plane& floor, const Plane& wall) {
  Plane out = wall;
  double offset = 0;
  if (wallOffset(g, floor, wall, 1.5, &offset)) out.d -= offset;
  return out;
}

bool wallStands(const PointGrid& g, const Plane& floor, const Plane& wall) {
  const double cell = g.step * Camera().xzFactor() / (g.width * g.step);  // cell size at 1 m, per m of depth
  double area = 0;
  int on = 0, behind = 0;
  for (int i = 0; i < g.width * g.height; ++i) {
    if (!g.ok(i) || (floor.found && floor.height(g.points[i]) < 0.05)) continue;
    const Vec3& p = g.points[i];
    const double d = wall.height(p), m = planeMargin(p.z);
    if (std::fabs(d) < m) { ++on; area += (p.z * cell) * (p.z * cell); }
    behind += d < -2 * m;
  }
  return area >= 1.0 && behind < on;
}

double DepthSteadier::correct(PointGrid* g) {
  const size_t n = g->points.size();
  if (ref_.size() != n) ref_.assign(n, 0.f);
  std::vector<double> diffs;
  for (size_t i = 0; i < n; ++i) {
    if (!g->valid[i] || ref_[i] <= 0) continue;
    const double d = 1.0 / g->points[i].z - ref_[i];
    if (std::fabs(d) < kSteadyBand) diffs.push_back(d);
  }
  // The reference holds the first frame's shift; the shifts' long mean (the
  // sensor's are centred on zero) takes it out slowly.
  const double shift = diffs.size() >= kSteadyCells ? median(diffs) : 0.0;
  mean_shift_ += kSteadyMeanRate * (shift - mean_shift_);
  for (size_t i = 0; i < n; ++i) {
    if (!g->valid[i]) continue;
    Vec3& p = g->points[i];
    const double steady = 1.0 / p.z - shift;
    if (steady <= 0) continue;
    ref_[i] = ref_[i] <= 0 ? static_cast<float>(steady) : static_cast<float>(ref_[i] + kSteadyRate * (steady - ref_[i]));
    const double out = steady + mean_shift_;
    if (out > 0) p = p * (1.0 / (out * p.z));
  }
  return shift - mean_shift_;
}

void Room::update(const PointGrid& g, double wall_hold) {
  const bool refit = frames_ % 30 == 0;
  if (!floor_.found || refit) {
    Plane f = fitFloor(g, 7 + frames_);
    if (f.found) floor_ = f;
  }
  std::vector<Plane> walls;
  if (refit) walls = fitWalls(g, floor_, 11 + frames_);
  ++frames_;
  // Walls held and not found again stay while the frame shows them.
  const size_t fresh = walls.size();
  for (const Plane& old : walls_) {
    const Plane w = followWall(g, floor_, old);
    bool again = false;
    for (size_t k = 0; k < fresh; ++k) {
      again |= walls[k].n.dot(w.n) > 0.985 && std::fabs(walls[k].d - w.d) < 2 * planeMargin(std::fabs(w.d));
    }
    if (!again && (!refit || wallStands(g, floor_, w))) walls.push_back(w);
  }
  walls_.swap(walls);
  const bool same_grid = wall_cells_.size() == g.points.size();
  wall_cells_ = hri_sync::wallCells(g, floor_, walls_, same_grid ? &wall_cells_ : nullptr, wall_hold);
}

std::vector<uint8_t> wallCells(const PointGrid& g, const Plane& floor, const std::vector<Plane>& walls,
                               const std::vector<uint8_t>* before, double hold) {
  const int n = g.width * g.height;
  std::vector<uint8_t> out(n, 0);
  for (int i = 0; i < n; ++i) {
    if (!g.ok(i)) {
      if (before) out[i] = (*before)[i];
      continue;
    }
    if (floor.found && floor.height(g.points[i]) < 0.05) continue;
    const double m = (before && (*before)[i] ? hold : 1.0) * planeMargin(g.points[i].z);
    for (const Plane& w : walls) out[i] |= std::fabs(w.height(g.points[i])) < m;
  }
  return out;
}

std::vector<Blob> blobs(const PointGrid& g, const Plane& floor, const std::vector<uint8_t>& wall_cells) {
  const int n = g.width * g.height;
  std::vector<int> comp(n, -1);
  std::vector<uint8_t> cand(n, 0);
  for (int i = 0; i < n; ++i) {
    if (!g.ok(i) || wall_cells[i]) continue;
    if (floor.found && floor.height(g.points[i]) < 0.05) continue;
    cand[i] = 1;
  }
  std::vector<Blob> parts;
  std::vector<int> stack;
  for (int s = 0; s < n; ++s) {
    if (!cand[s] || comp[s] >= 0) continue;
    Blob part;
    comp[s] = static_cast<int>(parts.size());
    stack.assign(1, s);
    while (!stack.empty()) {
      int i = stack.back();
      stack.pop_back();
      part.cells.push_back(i);
      const Vec3& p = g.points[i];
      forNeighbours(g, i, [&](int j) {
        if (!cand[j] || comp[j] >= 0 || std::fabs(g.points[j].z - p.z) > maxJump(p.z)) return;
        comp[j] = comp[s];
        stack.push_back(j);
      });
    }
    for (int i : part.cells) {
      const Vec3& p = g.points[i];
      part.centroid += p;
      double h = floor.found ? floor.height(p) : p.y + 1.0;
      part.lo = std::min(part.lo, h); part.hi = std::max(part.hi, h);
      part.xmin = std::min(part.xmin, p.x); part.xmax = std::max(part.xmax, p.x);
      part.zmin = std::min(part.zmin, p.z); part.zmax = std::max(part.zmax, p.z);
    }
    part.centroid = part.centroid * (1.0 / part.cells.size());
    parts.push_back(std::move(part));
  }
  return parts;
}

bool personSized(const PointGrid& g, const Blob& p) {
  // Tall as a person, no wider than arms spread, not a wall.
  if (p.cells.size() < 40 || p.hi - p.lo < 0.5 || p.hi > 2.5 || p.xmax - p.xmin > 2.2 || p.zmax - p.zmin > 1.6) {
    return false;
  }
  return thickness(g, p.cells, p.centroid) >= 0.025;  // flat: a wall, a cabinet, a door
}

std::string notAPerson(const PointGrid& g, const Blob& p, const Plane& floor) {
  auto height = [&](const Vec3& q) { return floor.found ? floor.height(q) : q.y + 1.0; };
  double head_lo = 1e9, head_hi = -1e9, chest_lo = 1e9, chest_hi = -1e9, leg_lo = 1e9, leg_hi = -1e9;
  for (int i : p.cells) {
    const Vec3& q = g.points[i];
    const double below_top = p.hi - height(q);
    if (height(q) >= 0.3 && height(q) <= 0.5) { leg_lo = std::min(leg_lo, q.x); leg_hi = std::max(leg_hi, q.x); }
    if (below_top <= 0.25) { head_lo = std::min(head_lo, q.x); head_hi = std::max(head_hi, q.x); }
    if (below_top >= 0.3 && below_top <= 0.6) { chest_lo = std::min(chest_lo, q.x); chest_hi = std::max(chest_hi, q.x); }
  }
  char why[160] = "";
  if (head_hi - head_lo > 0.5) {
    std::snprintf(why, sizeof why, "no head: its top is %.2f m across", head_hi - head_lo);
  } else if (!(chest_hi - chest_lo >= 0.2)) {
    std::snprintf(why, sizeof why, "no chest below its top (%.2f m across)", std::max(0.0, chest_hi - chest_lo));
  } else if (floor.found && p.hi < 1.0) {
    std::snprintf(why, sizeof why, "its top is %.2f m above the floor", p.hi);
  } else if (floor.found && p.lo > 0.5 * p.hi) {
    std::snprintf(why, sizeof why, "it does not stand: its lowest point is %.2f m above the floor", p.lo);
  } else if (floor.found && p.lo > 0.3 && openBelow(g, p) > 0.5) {  // no hidden legs: it hangs
    std::snprintf(why, sizeof why, "it hangs: %.2f m above the floor, the view open below it", p.lo);
  } else if (floor.found && leg_hi >= leg_lo && leg_hi - leg_lo < 0.05) {  // narrower than any leg seen side-on
    std::snprintf(why, sizeof why, "no legs: 0.3-0.5 m above the floor it is %.2f m across (a pole)", leg_hi - leg_lo);
  }
  return why;
}

double personScore(const Blob& p, const Vec3* prev_centroid) {
  if (!prev_centroid) return p.cells.size() * std::exp(-std::fabs(p.hi - 1.7) / 0.3);
  const double dist = (p.centroid - *prev_centroid).norm();
  return dist > 0.8 ? 0.0 : p.cells.size() / (0.1 + dist);
}

bool stacked(const Blob& top, const Blob& base) {
  const Vec3 off = top.centroid - base.centroid;
  return top.lo > base.lo + 0.5 && top.lo < base.hi + 0.1 && top.hi > base.hi && top.hi - base.lo < 2.5 &&
         std::hypot(off.x, off.z) < 0.5 && off.z < kStackedBehind;
}

namespace {

// One body cut in two at a depth step: either part rests on the other.
bool cutInTwo(const Blob& a, const Blob& b) { return stacked(a, b) || stacked(b, a); }

}  // namespace

bool isFragmentOf(const Blob& frag, const Blob& user) {
  if (cutInTwo(frag, user)) return true;
  if (frag.cells.size() > user.cells.size() / 3) return false;
  const Vec3 off = frag.centroid - user.centroid;
  return std::hypot(off.x, off.z) < 0.9 && frag.hi < user.hi + 0.3 && frag.lo > user.lo - 0.1;
}

Segmentation partSegmentation(int n, const std::vector<Blob>& parts, int user,
                              const std::vector<int>& fragments) {
  Segmentation seg;
  seg.mask.assign(n, 0);
  const Blob& u = parts[user];
  seg.cells = u.cells;
  for (int k : fragments) seg.cells.insert(seg.cells.end(), parts[k].cells.begin(), parts[k].cells.end());
  for (int i : seg.cells) seg.mask[i] = 1;
  // A body cut in two at a depth step is both parts: its height and centroid
  // are theirs together.
  double weight = static_cast<double>(u.cells.size());
  seg.centroid = u.centroid * weight;
  seg.height = u.hi;
  for (int k : fragments) {
    const Blob& f = parts[k];
    if (!cutInTwo(f, u)) continue;
    seg.centroid += f.centroid * static_cast<double>(f.cells.size());
    weight += static_cast<double>(f.cells.size());
    seg.height = std::max(seg.height, f.hi);
  }
  seg.centroid = seg.centroid * (1.0 / weight);
  seg.found = true;
  return seg;
}

Segmentation segmentUser(const PointGrid& g, const Plane& floor, const Vec3* prev_centroid,
                         const std::vector<Plane>& walls) {
  return segmentUser(g, floor, prev_centroid, wallCells(g, floor, walls));
}

Segmentation segmentUser(const PointGrid& g, const Plane& floor, const Vec3* prev_centroid,
                         const std::vector<uint8_t>& wall_cells) {
  const std::vector<Blob> parts = blobs(g, floor, wall_cells);
  int best = -1;
  double best_score = 0;
  for (size_t k = 0; k < parts.size(); ++k) {
    if (!personSized(g, parts[k])) continue;
    const double score = personScore(parts[k], prev_centroid);
    if (score > best_score) { best_score = score; best = static_cast<int>(k); }
  }
  if (best < 0) {
    Segmentation seg;
    seg.reason = parts.empty() ? "no points off the floor" : "no person-sized object in view";
    return seg;
  }
  // Fragments cut off by occlusion or by the floor (a foot, a hand) join the user.
  std::vector<int> fragments;
  for (size_t k = 0; k < parts.size(); ++k) {
    if (static_cast<int>(k) != best && isFragmentOf(parts[k], parts[best])) fragments.push_back(static_cast<int>(k));
  }
  return partSegmentation(g.width * g.height, parts, best, fragments);
}

std::string rangeCut(const PointGrid& g, const Segmentation& seg) {
  // A body sliced by the range piles up at it: most of what is seen of it lies
  // there (82-98 % of a still person's cells 5.05 m away). One whole in an open
  // room, the farthest thing the sensor reads, has the edge of its back there
  // (at most 7 % at 4.5 m), a dancer whose back reaches the range up to half.
  constexpr double kCutShare = 0.6;
  double far = 0;
  for (size_t i = 0; i < g.points.size(); ++i)
    if (g.ok(static_cast<int>(i))) far = std::max(far, g.points[i].z);
  const double edge = far - 2 * kKinectDepthStep * far * far;
  auto isVoid = [&](int x, int y) {
    int none = 0, all = 0;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= g.width || v >= g.height) continue;
        ++all;
        none += g.ok(v * g.width + u) ? 0 : 1;
      }
    return none * 5 >= all * 4;
  };
  double lo = 1e9, hi = -1e9;
  size_t at_edge = 0;
  for (int i : seg.cells) {
    if (g.points[i].z < edge) continue;
    ++at_edge;
    bool borders = false;
    forNeighbours(g, i, [&](int j) { borders = borders || (!g.ok(j) && isVoid(j % g.width, j / g.width)); }, 4);
    if (!borders) continue;
    lo = std::min(lo, g.points[i].x);
    hi = std::max(hi, g.points[i].x);
  }
  if (hi - lo <= kCutWidth || at_edge < kCutShare * seg.cells.size()) return "";
  char why[160];
  std::snprintf(why, sizeof why, "the body is cut by the sensor's range (%.2f m) over %.2f m, %.0f %% of it at the cut: "
                "the rest reads no depth", far, hi - lo, 100.0 * at_edge / seg.cells.size());
  return why;
}

std::string partialView(const PointGrid& g, const Segmentation& seg, const Plane& floor) {
  double nearest = 1e9;
  for (int i : seg.cells) nearest = std::min(nearest, g.points[i].z);
  for (int row : {g.height - 1, 0}) {
    double lo = 1e9, hi = -1e9, cut_height = 1e9;
    for (int i : seg.cells) {
      if (i / g.width != row) continue;
      lo = std::min(lo, g.points[i].x);
      hi = std::max(hi, g.points[i].x);
      if (floor.found) cut_height = std::min(cut_height, floor.height(g.points[i]));
    }
    // With the floor in view the body's height is known: a head cut by the top
    // edge or legs cut below mid-height leave most of it seen (zeroOutOfView
    // marks what is outside).
    if (floor.found && (row == 0 || cut_height < 0.5 * seg.height)) continue;
    if (hi - lo > kCutWidth) {
      char why[160];
      std::snprintf(why, sizeof why, "the body is cut by the image's %s edge over %.2f m (nearest point %.2f m): %s out of view",
                    row == 0 ? "top" : "bottom", hi - lo, nearest, row == 0 ? "head" : "legs");
      return why;
    }
  }
  return "";
}

void zeroOutOfView(const Camera& cam, const Joints& j, std::array<float, NUM_JOINTS>* conf) {
  for (int k = 0; k < NUM_JOINTS; ++k) {
    double u = -1, v = -1;
    if (j[k].z > 0.05) cam.project(j[k], &u, &v);
    if (!(u >= -0.5 && v >= -0.5 && u < cam.width - 0.5 && v < cam.height - 0.5)) (*conf)[k] = 0.f;
  }
}

Geodesic geodesicExtremities(const PointGrid& g, const Segmentation& seg, int max_extremities,
                             double min_length) {
  Geodesic geo;
  const int n = g.width * g.height;
  geo.dist.assign(n, kInf);
  geo.parent.assign(n, -1);
  if (!seg.found || seg.cells.empty()) return geo;
  double best = 1e18;
  for (int i : seg.cells) {
    double d = (g.points[i] - seg.centroid).norm();
    if (d < best) { best = d; geo.source = i; }
  }
  std::priority_queue<std::pair<float, int>, std::vector<std::pair<float, int>>, std::greater<std::pair<float, int>>> q;
  geo.dist[geo.source] = 0;
  q.push({0.f, geo.source});
  relax(g, seg.mask, &geo.dist, &geo.parent, &q);
  // Fragments not reached across the surface: bridge each through its nearest reached cell.
  for (int round = 0; round < 4; ++round) {
    int lone = -1, near = -1;
    double gap = 1e18;
    std::vector<int> reached;
    for (int i : seg.cells) if (geo.dist[i] < kInf) reached.push_back(i);
    for (int i : seg.cells) {
      if (geo.dist[i] < kInf) continue;
      for (size_t r = 0; r < reached.size(); r += 2) {
        double d = (g.points[i] - g.points[reached[r]]).norm();
        if (d < gap) { gap = d; lone = i; near = reached[r]; }
      }
    }
    if (lone < 0) break;
    geo.dist[lone] = geo.dist[near] + static_cast<float>(gap);
    geo.parent[lone] = near;
    q.push({geo.dist[lone], lone});
    relax(g, seg.mask, &geo.dist, &geo.parent, &q);
  }
  // Accumulative geodesic extrema: the farthest cell becomes a source in turn.
  std::vector<float> acc = geo.dist;
  for (int k = 0; k < max_extremities; ++k) {
    int far = -1;
    float fd = 0;
    for (int i : seg.cells) if (acc[i] < kInf && acc[i] > fd) { fd = acc[i]; far = i; }
    if (far < 0 || fd < min_length) break;
    geo.extremities.push_back(far);
    acc[far] = 0;
    q.push({0.f, far});
    relax(g, seg.mask, &acc, nullptr, &q);
  }
  return geo;
}

std::vector<int> pathToSource(const Geodesic& geo, int cell) {
  std::vector<int> path;
  for (int i = cell; i >= 0 && path.size() < geo.parent.size(); i = geo.parent[i]) path.push_back(i);
  return path;
}

BodyModel BodyModel::fromHeight(double h) {
  BodyModel m;
  m.height = h;
  m.upper_arm = 0.186 * h;
  m.forearm = 0.146 * h;
  m.shoulder_width = 0.17 * h;
  m.neck_drop = 0.02 * h;
  m.thigh = 0.245 * h;
  m.shin = 0.246 * h;
  m.hip_width = 0.11 * h;
  m.torso_to_neck = 0.144 * h;
  m.torso_to_hips = 0.144 * h;
  m.head_top = 0.085 * h;
  m.head_to_neck = 0.07 * h;
  return m;
}

BodyModel calibrateBody(const std::vector<CalibrationSample>& samples) {
  std::vector<double> heights, arms, legs;
  for (const auto& s : samples) {
    if (s.head_top_height > 0.8 && s.head_top_height < 2.4) heights.push_back(s.head_top_height);
    arms.insert(arms.end(), s.arm_reach.begin(), s.arm_reach.end());
    legs.insert(legs.end(), s.leg_reach.begin(), s.leg_reach.end());
  }
  BodyModel m = BodyModel::fromHeight(heights.empty() ? 1.70 : median(heights));
  // Limb reach (shoulder or hip to the tip) refines each limb's scale. A tip
  // farther than any limb reaches is something else (seen side-on, a still
  // person's far hand was a tip 1.3-1.4 times an arm away in 12 frames of 15,
  // and made the arms 20 % long): it is left out, not taken as the most.
  auto scale = [](std::vector<double> v, double expected) {
    v.erase(std::remove_if(v.begin(), v.end(), [&](double r) { return r > kMaxReach * expected; }), v.end());
    if (v.size() < 5) return 1.0;
    std::sort(v.begin(), v.end());
    double reach = v[v.size() * 9 / 10];
    return std::clamp(reach / expected, 1.0, 1.2);  // a bent limb reaches less: reach is a lower bound
  };
  double sa = scale(arms, m.upper_arm + m.forearm + 0.05);
  double sl = scale(legs, m.thigh + m.shin + 0.05);
  m.upper_arm *= sa;
  m.forearm *= sa;
  m.thigh *= sl;
  m.shin *= sl;
  m.calibrated = !heights.empty();
  return m;
}

DepthTracker::DepthTracker(const Camera& cam, TrackerParams params) : cam_(cam), params_(params) {
  if (params_.grid_step <= 0) params_.grid_step = std::max(1, cam.width / 160);
  reset();
}

DepthTracker::~DepthTracker() = default;

void DepthTracker::reset() {
  room_.reset();
  steadier_.reset();
  floor_ = Plane();
  model_ = target_ = BodyModel();
  calib_.clear();
  calib_frames_.clear();
  search_.reset();
  refine_frames_.clear();
  refined_ = false;
  refit_count_ = 0;
  have_prev_ = false;
  tip_age_.fill(1 << 20);
  lateral_ = Vec3(1, 0, 0);
  facing_ = Vec3(1, 0, 0);
  facing_votes_ = 0;
  facing_turns_ = 0;
  torso_bias_ = 0;
  have_fit_ = false;
  for (auto& f : filters_) f.reset();
}

TrunkFrame trunkFrame(const PointGrid& g, const Segmentation& seg, const Geodesic& geo, const Vec3& up,
                      const BodyModel& model, double torso_bias) {
  TrunkFrame tf;
  tf.up = up;
  int nt = 0;
  for (int i : seg.cells) if (geo.dist[i] < 0.22f) { tf.trunk += g.points[i]; ++nt; }
  tf.trunk = nt ? tf.trunk * (1.0 / nt) : seg.centroid;
  // The centroid sits low (legs are long): a learnt offset along up corrects it.
  tf.torso = behind(tf.trunk, 0.13) + up * torso_bias;
  tf.neck = tf.torso + up * model.torso_to_neck;
  tf.hipc = tf.torso - up * model.torso_to_hips;
  return tf;
}

Extremities findExtremities(const PointGrid& g, const Segmentation& seg, const Geodesic& geo, const Vec3& trunk) {
  Extremities ex;
  ex.cells = geo.extremities;
  const Vec3 view = trunk.normalized();
  std::vector<uint8_t> front(g.width * g.height, 0);
  for (int i : seg.cells) front[i] = (trunk - g.points[i]).dot(view) > 0.07;
  std::vector<int> stack;
  for (int s0 : seg.cells) {
    if (front[s0] != 1) continue;
    int tip = s0, size = 0;
    double best = -1;
    front[s0] = 2;
    stack.assign(1, s0);
    while (!stack.empty()) {
      int i = stack.back();
      stack.pop_back();
      ++size;
      double ahead = (trunk - g.points[i]).dot(view);
      if (ahead > best) { best = ahead; tip = i; }
      forNeighbours(g, i, [&](int jn) {
        if (front[jn] != 1 || std::fabs(g.points[jn].z - g.points[i].z) > maxJump(g.points[i].z)) return;
        front[jn] = 2;
        stack.push_back(jn);
      });
    }
    bool known = false;
    for (int c : ex.cells) known |= (g.points[c] - g.points[tip]).norm() < 0.15;
    if (size >= 3 && !known && ex.cells.size() < 10) ex.cells.push_back(tip);
  }
  for (int c : ex.cells) ex.points.push_back(g.points[c]);
  return ex;
}

namespace {

double aboveFloor(const Plane& floor, const Vec3& p) { return floor.found ? floor.height(p) : p.y + 1.0; }

// Cost of label l for candidate k (< 0: impossible). thigh: the candidate's
// path point 0.2 m below the hip centre (where a leg joins the pelvis).
double labelCost(int l, const Vec3& e, const Vec3& thigh, const TrunkFrame& tf, const Plane& floor,
                 const BodyModel& model, const LabelMemory& memory, double axis_top) {
  const double arm = model.upper_arm + model.forearm + 0.05;
  const double rise = (e - tf.torso).dot(tf.up);
  const double above_floor = aboveFloor(floor, e);
  double c = 0;
  if (l == LB_HEAD) {
    if (rise < 0.2) return -1;
    c = horizontal(e - tf.neck, tf.up).norm();
    // While the bone lengths are calibrated the user stands: nothing of the
    // body sits above the head on the trunk's axis (a shoulder or a chest
    // seen side-on is no head; raised hands stand off the axis).
    if (!model.calibrated) c += kBelowAxisTopCost * std::max(0.0, axis_top - above_floor - kHeadBelowTop);
  } else if (l == LB_LFOOT || l == LB_RFOOT) {
    if (above_floor > 0.45 || rise > -0.3) return -1;
    c = 0.5 * above_floor;
    // Feet cross in a dance step; legs stay on their own side at the pelvis.
    double side = (thigh - tf.hipc).dot(memory.lateral) * (l == LB_LFOOT ? 1 : -1);
    c += side < -0.04 ? 0.3 : 0;
  } else {
    if ((e - tf.neck).norm() > arm + 0.25 || above_floor < 0.25) return -1;
    double side = (e - tf.torso).dot(memory.lateral) * (l == LB_LHAND ? 1 : -1);
    c += side < -0.04 ? 0.3 : 0;
  }
  if (memory.have_prev && memory.age[l] <= memory.hold_frames) {
    double gate = 0.45 + 0.08 * memory.age[l];
    double d = (e - memory.tips[l]).norm();
    if (d > gate) return -1;
    c += d;
  }
  return c;
}

std::vector<Vec3> pathPoints(const PointGrid& g, const Geodesic& geo, int cell) {
  std::vector<Vec3> path;
  for (int c : pathToSource(geo, cell)) path.push_back(g.points[c]);
  return path;
}

}  // namespace

LabelAssignment labelExtremities(const PointGrid& g, const Geodesic& geo, const Extremities& ex,
                                 const TrunkFrame& tf, const Plane& floor, const BodyModel& model,
                                 const LabelMemory& memory) {
  const int m = static_cast<int>(ex.points.size());
  std::vector<Vec3> thigh(ex.points);
  for (int k = 0; k < m; ++k) {
    double best = 1e9;
    for (int c : pathToSource(geo, ex.cells[k])) {
      double off = std::fabs((g.points[c] - tf.hipc).dot(tf.up) + 0.2);
      if (off < best) { best = off; thigh[k] = g.points[c]; }
    }
  }
  // While calibrating, the highest candidate on the trunk's axis above the
  // torso (a head, or a hand held right above it).
  double axis_top = -1e9;
  if (!model.calibrated)
    for (const Vec3& e : ex.points)
      if ((e - tf.torso).dot(tf.up) >= 0.2 && horizontal(e - tf.neck, tf.up).norm() < kHeadAxis)
        axis_top = std::max(axis_top, aboveFloor(floor, e));
  std::vector<std::vector<double>> cost(NUM_LABELS, std::vector<double>(m));
  for (int l = 0; l < NUM_LABELS; ++l)
    for (int k = 0; k < m; ++k) cost[l][k] = labelCost(l, ex.points[k], thigh[k], tf, floor, model, memory, axis_top);
  // Exhaustive branch and bound: 5 labels over at most 10 candidates.
  const double miss = 0.6, miss_hand = 0.45;
  LabelAssignment assign, cur;
  assign.fill(-1);
  double best_cost = 1e18;
  std::vector<uint8_t> used(m, 0);
  std::function<void(int, double)> search = [&](int l, double c) {
    if (c >= best_cost) return;
    if (l == NUM_LABELS) { best_cost = c; assign = cur; return; }
    for (int k = 0; k < m; ++k) {
      if (used[k] || cost[l][k] < 0) continue;
      used[k] = 1;
      cur[l] = k;
      search(l + 1, c + cost[l][k]);
      used[k] = 0;
    }
    cur[l] = -1;
    search(l + 1, c + (l == LB_LHAND || l == LB_RHAND ? miss_hand : miss));
  };
  search(0, 0.0);
  return assign;
}

Vec3 kneeBend(const PointGrid& g, const Geodesic& geo, const Extremities& ex, const TrunkFrame& tf,
              const Plane& floor, const BodyModel& model, std::vector<Vec3>* legs_bend) {
  Vec3 bend_sum;
  int legs = 0;
  for (size_t k = 0; k < ex.points.size(); ++k) {
    if (aboveFloor(floor, ex.points[k]) > 0.45 || (ex.points[k] - tf.torso).dot(tf.up) > -0.3) continue;
    std::vector<Vec3> path = pathPoints(g, geo, ex.cells[k]);
    Vec3 knee = midJoint(path, tf.hipc, path.front(), model.thigh, model.shin, nullptr);
    Vec3 axis = (path.front() - tf.hipc).normalized();
    Vec3 off = knee - tf.hipc;
    const Vec3 bend = horizontal(off - axis * off.dot(axis), tf.up);
    bend_sum += bend;
    ++legs;
    if (legs_bend) legs_bend->push_back(bend);
  }
  return legs > 0 && bend_sum.norm() > 0.04 * legs ? bend_sum : Vec3();
}

BodyPose placeJoints(TrunkFrame tf, const std::array<std::vector<Vec3>, NUM_LABELS>& paths,
                     const std::array<Vec3, NUM_LABELS>& tips, const LabelAssignment& assign,
                     const BodyModel& model, const Vec3& lateral, const Joints* prev_mid) {
  auto at_reach = [](const std::vector<Vec3>& path, double reach) -> const Vec3* {
    for (const Vec3& p : path) if ((p - path.front()).norm() >= reach) return &p;
    return nullptr;
  };
  BodyPose out;
  const Vec3& up = tf.up;
  // Torso and neck down the head's path, when the head is seen.
  if (!paths[LB_HEAD].empty()) {
    const Vec3* pn = at_reach(paths[LB_HEAD], model.head_top + model.head_to_neck);
    const Vec3* pt = at_reach(paths[LB_HEAD], model.head_top + model.head_to_neck + model.torso_to_neck);
    if (pn && pt) {
      Vec3 t_new = behind(*pt, 0.13);
      out.torso_shift = (t_new - tf.torso).dot(up);
      tf.torso = t_new;
      tf.neck = behind(*pn, 0.12);
      tf.hipc = tf.torso - up * model.torso_to_hips;
    }
  }
  Joints& j = out.joints;
  auto& conf = out.confidence;
  conf.fill(0.5f);
  j[TORSO] = tf.torso;
  j[NECK] = tf.neck;
  conf[TORSO] = conf[NECK] = 0.8f;
  j[L_SHOULDER] = tf.neck + lateral * (model.shoulder_width / 2) - up * model.neck_drop;
  j[R_SHOULDER] = tf.neck - lateral * (model.shoulder_width / 2) - up * model.neck_drop;
  j[L_HIP] = tf.hipc + lateral * (model.hip_width / 2);
  j[R_HIP] = tf.hipc - lateral * (model.hip_width / 2);
  if (assign[LB_HEAD] >= 0) {
    j[HEAD] = tips[LB_HEAD] - up * model.head_top;
    conf[HEAD] = 0.9f;
  } else {
    j[HEAD] = tf.neck + up * (model.head_top + 0.05);
    conf[HEAD] = 0.3f;
  }
  // Arms and legs: tip -> end joint; middle joint on the path where both bones fit.
  struct Limb { int label; Joint root, mid, end; double upper, lower, r_mid, r_end, drop; };
  const Limb limbs[4] = {
      {LB_LHAND, L_SHOULDER, L_ELBOW, L_HAND, model.upper_arm, model.forearm, 0.045, 0.04, 0.0},
      {LB_RHAND, R_SHOULDER, R_ELBOW, R_HAND, model.upper_arm, model.forearm, 0.045, 0.04, 0.0},
      {LB_LFOOT, L_HIP, L_KNEE, L_FOOT, model.thigh, model.shin, 0.06, 0.05, 0.06},
      {LB_RFOOT, R_HIP, R_KNEE, R_FOOT, model.thigh, model.shin, 0.06, 0.05, 0.06}};
  for (const Limb& lb : limbs) {
    const Vec3 root = j[lb.root];
    const auto& path = paths[lb.label];
    if (!path.empty()) {
      const Vec3* endp = at_reach(path, 0.05);
      Vec3 end = endp ? *endp : path.front();
      double best;
      Vec3 mid = behind(midJoint(path, root, end, lb.upper, lb.lower, &best), lb.r_mid);
      j[lb.end] = behind(end, lb.r_end) - up * lb.drop;
      conf[lb.end] = 0.9f;
      conf[lb.mid] = 0.8f;
      if (best > 0.08) {  // the path skips the limb (held towards the sensor): two-bone fit
        Vec3 pole = prev_mid ? (*prev_mid)[lb.mid] - root : up * -1.0;
        mid = twoBone(root, j[lb.end], lb.upper, lb.lower, pole);
        conf[lb.mid] = 0.5f;
      }
      j[lb.mid] = mid;
    } else if (lb.label == LB_LHAND || lb.label == LB_RHAND) {
      // An unseen hand rests against the trunk (it would be an extremity otherwise).
      const double side = lb.label == LB_LHAND ? 1.0 : -1.0;
      const Vec3 forward = up.cross(lateral);
      j[lb.end] = tf.torso + forward * 0.13 + lateral * (0.07 * side);
      j[lb.mid] = twoBone(root, j[lb.end], lb.upper, lb.lower, lateral * (0.5 * side) - up);
      conf[lb.end] = conf[lb.mid] = 0.3f;
    } else {  // hanging limb of the model
      j[lb.mid] = root - up * lb.upper;
      j[lb.end] = root - up * (lb.upper + lb.lower);
      conf[lb.end] = conf[lb.mid] = 0.1f;
    }
  }
  return out;
}

Segmentation DepthTracker::segment(const PointGrid& g) {
  room_.update(g, params_.wall_hold);
  floor_ = room_.floor();
  return segmentUser(g, floor_, have_prev_ ? &prev_centroid_ : nullptr, room_.wallCells());
}

LabelMemory DepthTracker::memory() const {
  LabelMemory m;
  m.have_prev = have_prev_;
  m.tips = tips_;
  m.age = tip_age_;
  m.hold_frames = params_.hold_frames;
  m.lateral = lateral_;
  return m;
}

void DepthTracker::calibrate(const PointGrid& g, const Segmentation& seg, const Joints& j,
                             const LabelAssignment& assign) {
  if (!model_.calibrated) {
    CalibrationSample s;
    if (assign[LB_HEAD] >= 0) s.head_top_height = aboveFloor(floor_, tips_[LB_HEAD]);
    for (int l : {LB_LHAND, LB_RHAND})
      if (assign[l] >= 0) s.arm_reach.push_back((tips_[l] - j[l == LB_LHAND ? L_SHOULDER : R_SHOULDER]).norm());
    for (int l : {LB_LFOOT, LB_RFOOT})
      if (assign[l] >= 0) s.leg_reach.push_back((tips_[l] - j[l == LB_LFOOT ? L_HIP : R_HIP]).norm());
    calib_.push_back(s);
    if (calib_.size() % 2 == 0) calib_frames_.push_back({g, seg, floor_, j});
    if (static_cast<int>(calib_.size()) >= params_.calibration_frames) {
      model_ = calibrateBody(calib_);
      target_ = model_;
      // The calibration's frames span half a second: about one pose, which
      // cannot tell a longer arm seen end-on from the calibrated one (a
      // still person seen side-on had the search take the upper arm from
      // 0.36 to 0.47 m). The arms grow only in the second search.
      if (model_.calibrated)
        search_ = std::make_unique<ModelSearch>(cam_, std::move(calib_frames_), model_, /*grow_arms=*/false);
      calib_.clear();  // done (or no head seen yet: start over)
      calib_frames_.clear();
    }
  }
  // The bone lengths are refined on the kept frames, a few fits per frame.
  if (search_) {
    const bool over = search_->advance(kSearchFitsPerFrame);
    target_ = search_->best();
    if (over) search_.reset();
  }
  // The model the poses are fitted with follows the search's best slowly: a
  // length changed at once would move a still person's joints in one frame.
  if (model_.calibrated) model_ = towards(model_, target_, kModelStepPerFrame);
}

std::vector<Joints> armsToTips(const Joints& j, const std::array<int, NUM_JOINTS>& support,
                               const std::vector<Vec3>& tips, const BodyModel& model) {
  std::vector<Joints> out;
  const double reach = model.upper_arm + model.forearm;
  for (auto [root, mid, end] : {std::array<int, 3>{L_SHOULDER, L_ELBOW, L_HAND}, {R_SHOULDER, R_ELBOW, R_HAND}}) {
    if (support[end] >= kSeenPoints) continue;
    for (const Vec3& tip : tips) {
      // The hand joint about where placeJoints puts one: 5 cm back from the tip
      // towards the shoulder, 4 cm behind the surface.
      const Vec3 hand = behind(tip + (j[root] - tip).normalized() * 0.05, 0.04);
      if ((hand - j[root]).norm() > reach || (hand - j[end]).norm() < 0.15) continue;
      Joints a = j;
      a[end] = hand;
      a[mid] = twoBone(j[root], hand, model.upper_arm, model.forearm, j[mid] - j[root]);
      out.push_back(a);
    }
  }
  return out;
}

void DepthTracker::fit(const PointGrid& g, const Segmentation& seg, const std::vector<Vec3>& spare_tips,
                       Joints* j, std::array<float, NUM_JOINTS>* conf) {
  // Soles go to the floor once the first length search is over: with the
  // rough first lengths the pull would drag the trunk down instead.
  PoseFitParams fp;
  fp.ground = refined_ || !search_;
  PoseFitter fitter(cam_, g, seg, floor_, model_, fp);
  PoseFit best = fitter.fit(*j);
  if (have_fit_) {
    PoseFit cont = fitter.fit(prev_fit_);
    if (cont.energy < best.energy) best = cont;
    Joints swapped = best.joints;  // left and right arms exchanged
    for (auto [a, b] : {std::pair<int, int>{L_ELBOW, R_ELBOW}, {L_HAND, R_HAND}}) {
      swapped[a] = best.joints[b] - best.joints[R_SHOULDER] + best.joints[L_SHOULDER];
      swapped[b] = best.joints[a] - best.joints[L_SHOULDER] + best.joints[R_SHOULDER];
    }
    best = fitter.fitMixed(best.joints, {j, &prev_fit_, &swapped});
    // A hand the fit leaves unseen is tried at each extremity no label took
    // (a hand the labelling lost, against the body or taken for something
    // else, is often still a tip of the surface); kept when the fit is
    // better and the hands explain more depth points.
    for (const Joints& a : armsToTips(best.joints, best.support, spare_tips, model_)) {
      PoseFit f = fitter.fit(a, fp.iterations / 2);
      if (f.energy < best.energy && f.support[L_HAND] + f.support[R_HAND] > best.support[L_HAND] + best.support[R_HAND])
        best = f;
    }
  }
  // An arm that explains no depth point keeps last frame's fitted pose on
  // its shoulder, and an unseen elbow last frame's bend: with nothing to
  // hold them, the fit would let them drift (an elbow turns freely about the
  // shoulder-hand line).
  for (auto [root, mid, end] : {std::array<int, 3>{L_SHOULDER, L_ELBOW, L_HAND}, {R_SHOULDER, R_ELBOW, R_HAND}}) {
    if (!have_fit_ || best.support[mid] >= kSeenPoints) continue;
    Joints& b = best.joints;
    if (best.support[end] < kSeenPoints) b[end] = prev_fit_[end] - prev_fit_[root] + b[root];
    b[mid] = twoBone(b[root], b[end], model_.upper_arm, model_.forearm, prev_fit_[mid] - prev_fit_[root]);
  }
  *j = best.joints;
  prev_fit_ = *j;
  have_fit_ = true;
  keepForRefit(g, seg);
  // A joint whose capsules explain depth points is measured; one explaining
  // none is hidden and only inferred.
  for (int k : {HEAD, L_ELBOW, R_ELBOW, L_HAND, R_HAND, L_KNEE, R_KNEE, L_FOOT, R_FOOT})
    (*conf)[k] = best.support[k] >= kSeenPoints ? std::max((*conf)[k], 0.6f) : std::min((*conf)[k], 0.3f);
}

void DepthTracker::checkFacing(const std::vector<Vec3>& legs, const Vec3& up, Joints* j,
                               std::array<float, NUM_JOINTS>* conf) {
  // One knee's bend, or two that disagree, say little: a leg kicked back, a
  // noisy side view. Two bent the same way say where the front is.
  if (legs.size() != 2 || legs[0].norm() < kStrongBend || legs[1].norm() < kStrongBend ||
      legs[0].normalized().dot(legs[1].normalized()) < kBendsAgree)
    return;
  const Vec3 fitted = horizontal(rightToLeft(*j), up);
  facing_votes_ = (legs[0] + legs[1]).cross(up).dot(fitted) < 0 ? facing_votes_ + 1 : 0;
  if (facing_votes_ < kFacingVotes) return;
  facing_votes_ = 0;
  ++facing_turns_;
  for (auto [l, r] : {std::pair<int, int>{L_SHOULDER, R_SHOULDER}, {L_ELBOW, R_ELBOW}, {L_HAND, R_HAND},
                      {L_HIP, R_HIP}, {L_KNEE, R_KNEE}, {L_FOOT, R_FOOT}}) {
    std::swap((*j)[l], (*j)[r]);
    std::swap((*conf)[l], (*conf)[r]);
    std::swap(prev_fit_[l], prev_fit_[r]);
    std::swap(filters_[l], filters_[r]);
  }
}

void DepthTracker::keepForRefit(const PointGrid& g, const Segmentation& seg) {
  if (refined_ || search_ || ++refit_count_ % kRefitEvery != 0) return;
  refine_frames_.push_back({g, seg, floor_, prev_fit_});
  if (refine_frames_.size() < kRefitFrames) return;
  search_ = std::make_unique<ModelSearch>(cam_, std::move(refine_frames_), target_);
  refine_frames_.clear();
  refined_ = true;
}

Joints DepthTracker::smooth(const Joints& j, double t) {
  Joints out;
  for (int k = 0; k < NUM_JOINTS; ++k) {
    out[k] = filters_[k].filter(j[k], t, params_.filter);
  }
  return out;
}

SkeletonEstimate DepthTracker::update(const uint16_t* depth_mm, double t) {
  PointGrid g = makeGrid(depth_mm, cam_, params_.grid_step);
  if (params_.steady_depth) steadier_.correct(&g);
  Segmentation seg = segment(g);
  if (!seg.found) {
    lose();
    SkeletonEstimate out;
    out.state = "searching: " + seg.reason;
    return out;
  }
  return follow(g, seg, t);
}

void DepthTracker::lose() {
  have_prev_ = have_fit_ = false;
  for (auto& f : filters_) f.reset();
}

SkeletonEstimate DepthTracker::follow(const PointGrid& g, const Segmentation& seg, const Plane& floor, double t) {
  floor_ = floor;
  return follow(g, seg, t);
}

SkeletonEstimate DepthTracker::follow(const PointGrid& g, const Segmentation& seg, double t) {
  SkeletonEstimate out;
  out.user_cells = static_cast<int>(seg.cells.size());
  const std::string far = rangeCut(g, seg);
  const std::string partial = far.empty() ? partialView(g, seg, floor_) : far;
  if (!partial.empty()) {  // no skeleton made up for the unseen part; calibration waits
    have_prev_ = have_fit_ = false;
    out.state = (far.empty() ? "too close / partial view: " : "too far / partial view: ") + partial;
    return out;
  }
  Geodesic geo = geodesicExtremities(g, seg, 8, 0.5);
  out.extremities = static_cast<int>(geo.extremities.size());
  const Vec3 up = floor_.found ? floor_.n : Vec3(0, 1, 0);
  if (!model_.calibrated && calib_.empty()) model_ = BodyModel::fromHeight(std::clamp(seg.height + 0.03, 1.2, 2.2));
  const TrunkFrame tf = trunkFrame(g, seg, geo, up, model_, torso_bias_);
  const Extremities ex = findExtremities(g, seg, geo, tf.trunk);
  out.extremity_points = ex.points;
  // Facing: knees bend forward. The lateral axis (right to left) follows it.
  std::vector<Vec3> legs;
  const Vec3 bend = kneeBend(g, geo, ex, tf, floor_, model_, &legs);
  if (bend.norm() > 0) {
    facing_ = facing_ * 0.7 + bend.normalized().cross(up) * 0.3;
    if (facing_.norm() > 0.2) lateral_ = horizontal(facing_, up).normalized();
  }
  const LabelAssignment assign = labelExtremities(g, geo, ex, tf, floor_, model_, memory());
  std::array<std::vector<Vec3>, NUM_LABELS> paths;
  int found = 0;
  for (int l = 0; l < NUM_LABELS; ++l) {
    if (assign[l] < 0) { ++tip_age_[l]; continue; }
    ++found;
    tip_age_[l] = 0;
    tips_[l] = ex.points[assign[l]];
    paths[l] = pathPoints(g, geo, ex.cells[assign[l]]);
  }
  // The pole of a two-bone fit: last frame's fitted pose (the filtered one lags a dancer).
  Joints prev_mid = prev_fit_;
  if (!have_fit_) for (int k = 0; k < NUM_JOINTS; ++k) prev_mid[k] = filters_[k].value();
  BodyPose pose = placeJoints(tf, paths, tips_, assign, model_, lateral_, have_prev_ ? &prev_mid : nullptr);
  torso_bias_ += 0.2 * pose.torso_shift;
  calibrate(g, seg, pose.joints, assign);
  if (model_.calibrated) {
    // The first fitted pose starts the filters over: the rough poses before it
    // came from another estimator, and a still joint's filter would take
    // seconds to cross the gap.
    if (!have_fit_) for (auto& f : filters_) f.reset();
    std::vector<Vec3> spare;
    for (size_t i = 0; i < ex.points.size(); ++i)
      if (std::find(assign.begin(), assign.end(), static_cast<int>(i)) == assign.end()) spare.push_back(ex.points[i]);
    fit(g, seg, spare, &pose.joints, &pose.confidence);
    // A fast spin can leave the fit facing the wrong way round; strong knee bends turn it back.
    checkFacing(legs, up, &pose.joints, &pose.confidence);
  }
  out.joints = smooth(pose.joints, t);
  have_prev_ = true;
  prev_centroid_ = seg.centroid;
  out.confidence = pose.confidence;
  zeroOutOfView(cam_, out.joints, &out.confidence);
  out.labelled = found;
  out.tracked = model_.calibrated && found >= 2;
  out.state = model_.calibrated ? (out.tracked ? "tracking" : "tracking (few extremities)") : "calibrating";
  if (model_.calibrated) {
    out.body_height = model_.height;
    out.girth = model_.girth;
  }
  if (!out.tracked) out.confidence.fill(0.f);
  return out;
}

}  // namespace hri_sync
