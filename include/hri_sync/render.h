// Depth rendering of a body made of capsules around a 15-joint skeleton's
// bones, standing on a floor plane, with an optional background.
#pragma once

#include <cstdint>
#include <vector>

#include "hri_sync/body.h"

namespace hri_sync {

struct Capsule {
  Vec3 a, b;
  double radius;
};

struct RenderOptions {
  double floor_y = -1.0;       ///< floor plane y (m); the sensor is 1 m above it
  bool background = false;     ///< add a back wall and a cabinet
  double wall_z = 4.5;         ///< back wall distance (m)
  double max_range = 8.0;      ///< beyond this the pixel reads 0 (no return)
  double noise = 0.0;          ///< depth noise sigma at 1 m (m), grows with z^2
  uint32_t seed = 1;           ///< noise seed (per frame)
};

/// The capsules of the body model the virtual Kinect renders.
std::vector<Capsule> bodyCapsules(const Joints& j);

/// Renders depth in millimetres (0 = no return), row-major, cam.width x cam.height.
void renderDepth(const Joints& j, const Camera& cam, const RenderOptions& opt,
                 std::vector<uint16_t>* depth_mm);

}  // namespace hri_sync
