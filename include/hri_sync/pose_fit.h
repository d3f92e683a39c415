// Generative refinement of a skeleton: move the joints so that a body made of
// capsules around the bones explains the user's depth points, keeps out of the
// space the sensor sees through, and keeps its calibrated bone lengths.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hri_sync/body.h"
#include "hri_sync/depth_tracker.h"
#include "hri_sync/render.h"

namespace hri_sync {

struct PoseFitParams {
  int iterations = 12;
  double outlier = 0.10;       ///< residuals (m) beyond this pull no harder (Huber)
  double free_space = 1.0;     ///< weight of model surface seen in free space
  double margin = 0.03;        ///< depth tolerance of the free-space test (m)
  double stiffness = 2.0;      ///< points' worth of inertia per joint per iteration
  /// Pull the sole of a leg seen down to the floor band onto the floor: the
  /// bone-length search's cue for the leg's length, which the band hides.
  bool ground = false;
};

struct PoseFit {
  Joints joints;
  double energy = 0;                    ///< robust residual per depth point (m^2)
  /// Depth points explained next to each joint; an arm's count only points
  /// that no other part explains within the depth noise.
  std::array<int, NUM_JOINTS> support{};
};

/// Fits poses to one frame's user; the torso keeps the model's shape, the limbs
/// its bone lengths, every joint stays above the floor.
class PoseFitter {
 public:
  PoseFitter(const Camera& cam, const PointGrid& g, const Segmentation& seg, const Plane& floor,
             const BodyModel& m, const PoseFitParams& p = PoseFitParams());
  /// The pose reached from init (iterations: 0 = the parameters').
  PoseFit fit(const Joints& init, int iterations = 0) const;
  /// fit, then each limb tried again from where each alternative pose holds it.
  PoseFit fitMixed(const Joints& init, const std::vector<const Joints*>& alternatives) const;

 private:
  struct Bone {
    int a, b;
    double length, wa;  ///< wa: the first joint's share of a correction
  };
  /// One iteration (move) or only the energy; support counts points per joint;
  /// hint: per user cell, the capsule that explained it last (-1: none yet).
  double step(Joints* j, std::vector<int8_t>* hint, std::array<int, NUM_JOINTS>* support, bool move) const;
  void constrain(Joints* j) const;
  /// The model's body: the head ball, then the virtual Kinect's capsules (render.h).
  const BodyPart& part(int c) const { return c == 0 ? head_ : parts_[c - 1]; }

  Camera cam_;
  const PointGrid& g_;
  const Segmentation& seg_;
  Plane floor_;
  PoseFitParams p_;
  std::vector<int> nearest_;   ///< per grid cell: the nearest user cell
  std::vector<Bone> bones_;
  BodyPart head_;
  std::array<BodyPart, kBodyParts.size()> parts_;  ///< kBodyParts, the girth's radii scaled
};

/// from with each searched length moved towards to's by at most max_step of itself.
BodyModel towards(const BodyModel& from, const BodyModel& to, double max_step);

/// The search for the bone lengths, trunk proportions and girth with which the model
/// explains kept frames best: coordinate descent over each length's scale from
/// a start, a few pose fits at a time so that tracking goes on meanwhile.
class ModelSearch {
 public:
  /// grow_arms false: the arms' lengths may only shrink (frames of one pose
  /// cannot tell a longer arm seen end-on from the start's).
  ModelSearch(const Camera& cam, std::vector<FitFrame> frames, const BodyModel& start, bool grow_arms = true);
  /// Runs up to fits pose fits; true once the search is over.
  bool advance(int fits);
  /// The best model so far.
  const BodyModel& best() const { return best_; }

 private:
  void next(double energy);

  Camera cam_;
  std::vector<FitFrame> frames_;
  BodyModel prior_, best_, cand_;
  double best_e_ = 0, cand_e_ = 0;
  size_t frame_ = 0;
  int step_ = 0, round_ = 0, param_ = 0;
  int dir_ = -1;  ///< -1: evaluating the start; 0: scaling up; 1: scaling down
  bool moved_ = false, done_ = false;
  bool grow_arms_ = true;
};

}  // namespace hri_sync
