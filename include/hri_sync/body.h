// Shared geometry for the skeleton tracker and the virtual Kinect: 3-vectors,
// the 15 OpenNI/NiTE joints, the depth camera model and .track joint files.
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace hri_sync {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3() = default;
  Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  Vec3 cross(const Vec3& o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  double norm() const { return std::sqrt(dot(*this)); }
  Vec3 normalized() const { double n = norm(); return n > 1e-12 ? *this * (1.0 / n) : Vec3(); }
  bool finite() const { return std::isfinite(x) && std::isfinite(y) && std::isfinite(z); }
};

/// Joint indices, in the fixed order of hri_sync/Skeleton (hri_sync.dance_off.joints).
enum Joint {
  HEAD = 0, NECK, TORSO, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_HAND, R_HAND,
  L_HIP, R_HIP, L_KNEE, R_KNEE, L_FOOT, R_FOOT, NUM_JOINTS
};
extern const char* const kJointNames[NUM_JOINTS];

using Joints = std::array<Vec3, NUM_JOINTS>;

/// The body's right-to-left axis, shoulders' and hips' together (not normalized):
/// it and the truth's pointing apart is a skeleton facing the wrong way round.
inline Vec3 rightToLeft(const Joints& j) { return j[L_SHOULDER] - j[R_SHOULDER] + j[L_HIP] - j[R_HIP]; }

/// Pinhole model of a depth camera with OpenNI's world convention (metres,
/// x right as seen by the sensor, y up, z along the optical axis).
struct Camera {
  int width = 320, height = 240;

  Camera() { setFov(1.0225, 0.7959); }  // Kinect v1 depth: 58.6 x 45.6 degrees
  /// Fields of view (rad); the tangents the hot loops project with are kept.
  void setFov(double h, double v) {
    hfov_ = h;
    vfov_ = v;
    xz_ = 2.0 * std::tan(h / 2.0);
    yz_ = 2.0 * std::tan(v / 2.0);
  }
  double hfov() const { return hfov_; }
  double vfov() const { return vfov_; }
  double xzFactor() const { return xz_; }
  double yzFactor() const { return yz_; }
  /// Direction (with z = 1) of the ray through the centre of pixel (u, v).
  Vec3 ray(double u, double v) const {
    return {((u + 0.5) / width - 0.5) * xzFactor(), (0.5 - (v + 0.5) / height) * yzFactor(), 1.0};
  }
  Vec3 toWorld(double u, double v, double z) const { return ray(u, v) * z; }
  /// Pixel coordinates of a world point (z > 0).
  void project(const Vec3& p, double* u, double* v) const {
    *u = (p.x / (p.z * xzFactor()) + 0.5) * width - 0.5;
    *v = (0.5 - p.y / (p.z * yzFactor())) * height - 0.5;
  }

 private:
  double hfov_, vfov_, xz_, yz_;
};

/// A joint track: the plain-text format of data/motion/*.track.
class Track {
 public:
  /// Throws std::runtime_error with the file and line on any malformed input.
  static Track load(const std::string& path);
  static Track fromFrames(std::vector<double> times, std::vector<Joints> frames);

  double duration() const { return times_.empty() ? 0.0 : times_.back(); }
  size_t size() const { return times_.size(); }
  const std::vector<double>& times() const { return times_; }
  const std::vector<Joints>& frames() const { return frames_; }
  /// Joints at time t (s), linearly interpolated; t wraps around when loop.
  Joints at(double t, bool loop = true) const;

 private:
  std::vector<double> times_;
  std::vector<Joints> frames_;
};

}  // namespace hri_sync
