// Depth rendering of a body made of capsules around a 15-joint skeleton's
// bones, standing on a floor plane, with an optional background.
#pragma once

#include <array>
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

/// A capsule end fixed to the skeleton: joint i moved w of the way towards joint k.
struct CapsuleEnd {
  int i, k;
  double w;
  Vec3 at(const Joints& j) const { return j[i] + (j[k] - j[i]) * w; }
};
/// A capsule between two ends fixed to the skeleton.
struct BodyPart {
  CapsuleEnd a, b;
  double radius;
  bool girth = false;  ///< the tracker scales its radius by the person's girth (BodyModel::girth)
};
constexpr CapsuleEnd atJoint(int i) { return {i, i, 0.0}; }

/// The foot: a ball on the shin's line, its centre this share of the shin
/// above the foot joint (about 4 cm), so that the foot joint is the sole.
inline constexpr double kFootBall = 0.09;

/// The body below the head (radii of an average adult): the virtual Kinect
/// renders these capsules (`body=model`) and the tracker's model fit assumes
/// the same shape, the trunk's and thighs' radii scaled by the girth it
/// measures per person. The fifth part is the chest, a third of the way from
/// the shoulders down to the torso joint.
inline constexpr std::array<BodyPart, 20> kBodyParts = {{
    {atJoint(NECK), atJoint(HEAD), 0.055},
    {{NECK, TORSO, 0.1}, atJoint(TORSO), 0.10, true},
    {atJoint(TORSO), {L_HIP, R_HIP, 0.5}, 0.12, true},
    {atJoint(L_SHOULDER), atJoint(R_SHOULDER), 0.06, true},
    {{L_SHOULDER, TORSO, 1.0 / 3}, {R_SHOULDER, TORSO, 1.0 / 3}, 0.09, true},
    {atJoint(L_SHOULDER), atJoint(L_HIP), 0.09, true},
    {atJoint(R_SHOULDER), atJoint(R_HIP), 0.09, true},
    {atJoint(L_HIP), atJoint(R_HIP), 0.09, true},
    {atJoint(L_SHOULDER), atJoint(L_ELBOW), 0.05},
    {atJoint(R_SHOULDER), atJoint(R_ELBOW), 0.05},
    {atJoint(L_ELBOW), atJoint(L_HAND), 0.04},
    {atJoint(R_ELBOW), atJoint(R_HAND), 0.04},
    {atJoint(L_HAND), atJoint(L_HAND), 0.05},
    {atJoint(R_HAND), atJoint(R_HAND), 0.05},
    {atJoint(L_HIP), atJoint(L_KNEE), 0.075, true},
    {atJoint(R_HIP), atJoint(R_KNEE), 0.075, true},
    {atJoint(L_KNEE), {L_FOOT, L_KNEE, kFootBall}, 0.055},
    {atJoint(R_KNEE), {R_FOOT, R_KNEE, kFootBall}, 0.055},
    {{L_FOOT, L_KNEE, kFootBall}, {L_FOOT, L_KNEE, kFootBall}, 0.045},
    {{R_FOOT, R_KNEE, kFootBall}, {R_FOOT, R_KNEE, kFootBall}, 0.045},
}};

/// The head: a ball of kHeadRadius whose centre lies kHeadAbove beyond the head
/// joint along the neck-to-head line (the head joint sits at the skull's base).
inline constexpr double kHeadRadius = 0.10;
inline constexpr double kHeadAbove = 0.045;

/// The capsules of the body model the virtual Kinect renders: the head ball,
/// then kBodyParts.
std::vector<Capsule> bodyCapsules(const Joints& j);

/// Ray-capsule distance from origin o along the unit direction rd, or -1.
double intersectCapsule(const Vec3& o, const Vec3& rd, const Capsule& cap);

/// The pixel box (inclusive) a capsule covers seen from o; false when it is
/// off-screen or reaches behind the camera.
bool capsulePixelBox(const Capsule& cap, const Vec3& o, const Camera& cam, int* u0, int* u1, int* v0, int* v1);

/// Renders depth in millimetres (0 = no return), row-major, cam.width x cam.height.
void renderDepth(const Joints& j, const Camera& cam, const RenderOptions& opt,
                 std::vector<uint16_t>* depth_mm);

}  // namespace hri_sync
