#include "hri_sync/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace hri_sync {

std::vector<Capsule> bodyCapsules(const Joints& j) {
  Vec3 up = (j[HEAD] - j[NECK]).normalized();
  std::vector<Capsule> c = {{j[HEAD] + up * (kHeadAbove - 0.005), j[HEAD] + up * (kHeadAbove + 0.005), kHeadRadius}};
  for (const BodyPart& p : kBodyParts) c.push_back({p.a.at(j), p.b.at(j), p.radius});
  return c;
}

bool capsulePixelBox(const Capsule& cap, const Vec3& o, const Camera& cam, int* u0, int* u1, int* v0, int* v1) {
  if (!cap.a.finite() || !cap.b.finite()) return false;
  double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
  for (const Vec3& end : {cap.a - o, cap.b - o}) {
    for (int k = 0; k < 8; ++k) {
      double r = cap.radius;
      Vec3 w = end + Vec3((k & 1) ? r : -r, (k & 2) ? r : -r, (k & 4) ? r : -r);
      if (w.z < 0.05) return false;
      double u, v;
      cam.project(w, &u, &v);
      umin = std::min(umin, u); umax = std::max(umax, u);
      vmin = std::min(vmin, v); vmax = std::max(vmax, v);
    }
  }
  *u0 = std::max(0, static_cast<int>(std::floor(umin)));
  *u1 = std::min(cam.width - 1, static_cast<int>(std::ceil(umax)));
  *v0 = std::max(0, static_cast<int>(std::floor(vmin)));
  *v1 = std::min(cam.height - 1, static_cast<int>(std::ceil(vmax)));
  return *u0 <= *u1 && *v0 <= *v1;
}

void renderDepth(const Joints& j, const Camera& cam, const RenderOptions& opt,
                 std::vector<uint16_t>* depth_mm) {
  const int W = cam.width, H = cam.height;
  std::vector<float> z(static_cast<size_t>(W) * H, std::numeric_limits<float>::infinity());
  // Floor and background.
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      Vec3 d = cam.ray(u, v);
      float& zz = z[v * W + u];
      if (d.y < -1e-6) zz = std::min<double>(zz, opt.floor_y / d.y);
      if (opt.background) {
        zz = std::min<double>(zz, opt.wall_z);
        // A cabinet 0.8 m wide, 1.2 m high, front face at z = 3.6 m, left of centre.
        double bz = 3.6, x = d.x * bz, y = d.y * bz;
        if (x > -2.0 && x < -1.2 && y > opt.floor_y && y < opt.floor_y + 1.2) zz = std::min<double>(zz, bz);
      }
    }
  }
  // Body capsules, each over its projected bounding box.
  for (const Capsule& cap : bodyCapsules(j)) {
    int u0, u1, v0, v1;
    if (!capsulePixelBox(cap, Vec3(), cam, &u0, &u1, &v0, &v1)) continue;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        Vec3 d = cam.ray(u, v);
        double n = d.norm();
        double t = intersectCapsule(Vec3(), d * (1.0 / n), cap);
        if (t > 0) {
          float zz = static_cast<float>(t / n);
          float& dst = z[v * W + u];
          if (zz < dst) dst = zz;
        }
      }
    }
  }
  depth_mm->assign(z.size(), 0);
  std::mt19937 rng(opt.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (size_t i = 0; i < z.size(); ++i) {
    double zz = z[i];
    if (!(zz < opt.max_range) || zz < 0.4) continue;  // the Kinect sees nothing nearer than 0.4 m
    if (opt.noise > 0) zz += gauss(rng) * opt.noise * zz * zz;
    (*depth_mm)[i] = static_cast<uint16_t>(std::lround(std::max(0.0, zz) * 1000.0));
  }
}

}  // namespace hri_sync
