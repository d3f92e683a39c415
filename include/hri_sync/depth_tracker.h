// The open depth-only skeleton tracker: segment the user from floor and
// background, find extremities (head, hands, feet) by geodesic distance over
// the body, place the other joints with a kinematic body model whose bone
// lengths are calibrated on the first frames, and smooth over time.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hri_sync/body.h"
#include "hri_sync/joint_filter.h"

namespace hri_sync {

/// The depth image subsampled to a grid of 3-D points (metres).
struct PointGrid {
  int width = 0, height = 0, step = 1;
  std::vector<Vec3> points;
  std::vector<uint8_t> valid;
  bool ok(int i) const { return valid[i] != 0; }
};
PointGrid makeGrid(const uint16_t* depth_mm, const Camera& cam, int step);

/// Plane n.p + d = 0 with unit normal n pointing up.
struct Plane {
  Vec3 n{0, 1, 0};
  double d = 1.0;
  bool found = false;
  double height(const Vec3& p) const { return n.dot(p) + d; }
};
/// RANSAC fit of the floor (a plane whose normal is within 30 degrees of +y).
Plane fitFloor(const PointGrid& g, uint32_t seed = 7);

/// Sequential RANSAC (Fischler and Bolles 1981) for the large vertical planes
/// behind a person (walls, a door, a cupboard front): up to max_planes planes
/// whose normal is within 30 degrees of horizontal (across the floor's normal),
/// each holding more than 1.5 m^2 of surface and spanning more than 1 m both
/// across and up, which no person does, and hiding what is behind it (at most
/// 25 % of the cells within its image box show something behind it or no
/// return: people standing side by side at one depth make a plane as large
/// but not a wall). Points within planeMargin of one are background.
std::vector<Plane> fitWalls(const PointGrid& g, const Plane& floor, uint32_t seed = 11, int max_planes = 3);
/// How far (m) a point at depth z may lie off a plane it belongs to: 3 cm plus
/// the Kinect v1 depth step and noise (~1.25 steps of 2.85e-3 z^2).
double planeMargin(double z);
/// The wall moved along its normal to this frame's depth of it: the mean offset
/// of the points within 1.5 margins of it, trimmed to one margin about their
/// median; unchanged when fewer than 50 cells show it.
Plane followWall(const PointGrid& g, const Plane& floor, const Plane& wall);
/// Whether this frame still shows the wall: at least 1 m^2 of points on it
/// and fewer cells behind it (more than two margins) than on it.
bool wallStands(const PointGrid& g, const Plane& floor, const Plane& wall);

/// The cells on a wall (1) and off it (0): within planeMargin of one of walls,
/// off the floor. With before (last frame's cells, same grid) a cell that was
/// on a wall stays on it while within hold margins: a hand or a back held
/// against a wall, read through a Kinect's noise, would otherwise come and go
/// at the margin from frame to frame. A cell with no reading keeps its state.
std::vector<uint8_t> wallCells(const PointGrid& g, const Plane& floor, const std::vector<Plane>& walls,
                               const std::vector<uint8_t>* before = nullptr, double hold = 1.0);

/// The room: the floor and the background planes, kept steady from frame to
/// frame. Both are refitted every 30 frames. Each frame, every wall follows the
/// frame's depth (a Kinect v1 shifts the depth of a whole frame now and then,
/// by centimetres at 4 m); a refit that misses a wall the room holds (most of
/// it read as no return in this frame, or hidden) keeps the wall while the
/// frame still shows it (wallStands).
class Room {
 public:
  /// The room on this frame's grid; wall_hold: wallCells' hold.
  void update(const PointGrid& g, double wall_hold);
  void reset() { *this = Room(); }
  const Plane& floor() const { return floor_; }
  const std::vector<Plane>& walls() const { return walls_; }
  /// This frame's wall cells, held from frame to frame (wallCells).
  const std::vector<uint8_t>& wallCells() const { return wall_cells_; }

 private:
  Plane floor_;
  std::vector<Plane> walls_;
  std::vector<uint8_t> wall_cells_;
  int frames_ = 0;
};

/// A Kinect v1 now and then shifts the disparity of a whole frame: every depth
/// moves by the same step of 1/z (centimetres at 4 m). The shift is measured
/// as the median change of 1/z, against a running reference, over the cells
/// that read nearly what they read before (the background, a still person;
/// someone moving reads far off and is left out), and taken out of the frame.
class DepthSteadier {
 public:
  /// Corrects g in place; returns the shift taken out (1/m).
  double correct(PointGrid* g);
  void reset() {
    ref_.clear();
    mean_shift_ = 0;
  }

 private:
  std::vector<float> ref_;  ///< per cell: its corrected 1/z, low-passed (0: none yet)
  double mean_shift_ = 0;   ///< the measured shifts' running mean (1/m)
};

struct Segmentation {
  std::vector<int> cells;        ///< grid indices of the user
  std::vector<uint8_t> mask;     ///< per grid cell: 1 = user
  Vec3 centroid;
  double height = 0;             ///< extent along the floor normal (m)
  bool found = false;
  std::string reason;            ///< why nothing was found
};
/// A connected body of points off the floor and the walls (neighbours whose
/// depths differ by less than 5 cm + 2 cm/m), with its extent: heights above
/// the floor (lo, hi), x and z (m).
struct Blob {
  std::vector<int> cells;
  Vec3 centroid;
  double lo = 1e9, hi = -1e9, xmin = 1e9, xmax = -1e9, zmin = 1e9, zmax = -1e9;
};
std::vector<Blob> blobs(const PointGrid& g, const Plane& floor, const std::vector<uint8_t>& wall_cells);
/// Whether a part may be a person: 0.5-2.5 m tall, at most 2.2 m wide and 1.6 m
/// deep, at least 40 cells, and not flat (walls, cabinets, doors are).
bool personSized(const PointGrid& g, const Blob& p);
/// Why a person-sized part is not a person to start tracking (empty: it may be
/// one): a head at its top (at most 0.5 m across in its top 0.25 m), a chest
/// below it (at least 0.2 m across 0.3-0.6 m below the top), and, with the
/// floor in view, a top at least 1 m
/// above the floor and a lowest point in the lower half of that height
/// (something standing, not something on a shelf), and a lowest point within
/// 0.3 m of the floor unless what is below it is hidden (by something nearer,
/// the image's edge or no reading): a coat on a stand hangs with the view open
/// below it; a person's legs are hidden, never missing. What is seen 0.3-0.5 m
/// above the floor is at least 0.05 m across (a slim leg side-on measures
/// 0.07-0.09 m on the grid), not a pole (a coat stand's, 0.03 m).
std::string notAPerson(const PointGrid& g, const Blob& p, const Plane& floor);
/// How much a person-sized part looks like the user: with no previous
/// centroid, its size weighted by how close its top is to 1.7 m; with one,
/// its size over (0.1 m + its distance from it), 0 beyond 0.8 m.
double personScore(const Blob& p, const Vec3* prev_centroid);
/// Whether top rests on base as one body cut in two at a depth step (the upper
/// body off the legs in a side view): it starts at base's top (0.5 m or more
/// above its bottom), rises above it, and its centroid is within 0.5 m of
/// base's across the floor (an arm may reach out of base's box) and at most
/// 0.2 m farther from the sensor (a taller person right behind is no part).
bool stacked(const Blob& top, const Blob& base);
/// Whether frag is a piece of user: a small piece cut off by occlusion or by the
/// floor (a foot, a hand: at most a third of its size, within 0.9 m across the
/// floor), or the rest of a body cut in two (stacked, either way).
bool isFragmentOf(const Blob& frag, const Blob& user);
/// The segmentation of parts[user] with the given fragments joined (n: grid cells).
Segmentation partSegmentation(int n, const std::vector<Blob>& parts, int user, const std::vector<int>& fragments);

/// The user: the connected body of points off the floor that looks most like a
/// standing person (or lies nearest prev_centroid when given).
/// walls: background planes (fitWalls) whose points are removed first;
/// wall_cells: the same given as cells (Room::wallCells).
Segmentation segmentUser(const PointGrid& g, const Plane& floor, const Vec3* prev_centroid,
                         const std::vector<uint8_t>& wall_cells);
Segmentation segmentUser(const PointGrid& g, const Plane& floor, const Vec3* prev_centroid,
                         const std::vector<Plane>& walls = {});

/// Why the user is only partly in view ("" when the whole body is): a body cut
/// by the image's bottom edge (legs out of view) or top edge (head out of view)
/// over more than a hand's width. A hand or foot crossing an edge does not count;
/// with the floor in view, neither does a top cut nor a bottom cut in the lower
/// half of the body (most of it is seen; zeroOutOfView marks the joints out of view).
std::string partialView(const PointGrid& g, const Segmentation& seg, const Plane& floor);

/// Why the user is only partly within the sensor's range ("" when not): 60 % or
/// more of the user's cells lie within two depth steps of the farthest depth the
/// frame reads, and those border a void (no return all round, not a dropout's
/// speck) over more than a hand's width. Beyond its range the sensor reads
/// nothing, and the rest of the body is not seen (a walker leaving a Kinect v1's
/// 5 m).
std::string rangeCut(const PointGrid& g, const Segmentation& seg);

/// Confidence 0 for every joint the camera cannot see (outside the image or
/// behind the sensor): such a joint is never measured, only inferred.
void zeroOutOfView(const Camera& cam, const Joints& j, std::array<float, NUM_JOINTS>* conf);

/// Geodesic distances over the user's surface (8-neighbour grid graph).
struct Geodesic {
  std::vector<float> dist;       ///< from the source; inf off the body
  std::vector<int> parent;       ///< shortest-path tree towards the source
  int source = -1;
  std::vector<int> extremities;  ///< accumulative geodesic extrema, best first
};
/// Distances from the body cell nearest the centroid and up to max_extremities
/// accumulative geodesic extrema at least min_length from the source.
Geodesic geodesicExtremities(const PointGrid& g, const Segmentation& seg, int max_extremities = 8,
                             double min_length = 0.3);
/// Cells from cell back to the source along the shortest-path tree.
std::vector<int> pathToSource(const Geodesic& geo, int cell);

/// Body model: segment lengths (m), calibrated from the user's height and limb reach.
struct BodyModel {
  double height = 1.70;
  double upper_arm = 0.30, forearm = 0.27, shoulder_width = 0.36, neck_drop = 0.03;
  double thigh = 0.42, shin = 0.42, hip_width = 0.20;
  double torso_to_neck = 0.25, torso_to_hips = 0.22, head_top = 0.15, head_to_neck = 0.12;
  double girth = 1.0;  ///< the trunk's and thighs' radii against the average adult's (render.h)
  bool calibrated = false;
  /// Proportions of a height (Drillis and Contini's segment table).
  static BodyModel fromHeight(double h);
};

/// Calibration samples: per frame, the head top's height above the floor and
/// the reach from shoulder level to each hand/foot tip when seen.
struct CalibrationSample {
  double head_top_height = 0;
  std::vector<double> arm_reach, leg_reach;
};
BodyModel calibrateBody(const std::vector<CalibrationSample>& samples);

/// One frame kept for calibration: the user's points and a first pose.
struct FitFrame {
  PointGrid grid;
  Segmentation seg;
  Plane floor;
  Joints init;
};

/// The extremities the labelling stage names (head, hands, feet).
enum ExtremityLabel { LB_HEAD, LB_LHAND, LB_RHAND, LB_LFOOT, LB_RFOOT, NUM_LABELS };
using LabelAssignment = std::array<int, NUM_LABELS>;  ///< candidate per label, -1: unseen

/// The trunk as the body model places it: the body within a short geodesic
/// radius of the centroid, the torso behind its surface, neck and hip centre
/// along up.
struct TrunkFrame {
  Vec3 up{0, 1, 0}, trunk, torso, neck, hipc;
};
TrunkFrame trunkFrame(const PointGrid& g, const Segmentation& seg, const Geodesic& geo, const Vec3& up,
                      const BodyModel& model, double torso_bias);

/// Stage "extremities": the geodesic extrema, plus the tips of parts held out
/// in front of the trunk towards the sensor (a hand reaching forward), which
/// are no geodesic extrema. Cells and their points, at most 10.
struct Extremities {
  std::vector<int> cells;
  std::vector<Vec3> points;
};
Extremities findExtremities(const PointGrid& g, const Segmentation& seg, const Geodesic& geo, const Vec3& trunk);

/// What the labelling remembers between frames.
struct LabelMemory {
  bool have_prev = false;
  std::array<Vec3, NUM_LABELS> tips;
  std::array<int, NUM_LABELS> age{};
  int hold_frames = 10;       ///< how long a lost extremity's last position gates it
  Vec3 lateral{1, 0, 0};      ///< right to left
};

/// Stage "labelling": the cheapest assignment of candidates to head, hands and
/// feet that obeys the body's shape (extra extrema, knees and elbows, stay
/// unlabelled); the cost adds the distance to a label's recent last position.
LabelAssignment labelExtremities(const PointGrid& g, const Geodesic& geo, const Extremities& ex,
                                 const TrunkFrame& tf, const Plane& floor, const BodyModel& model,
                                 const LabelMemory& memory);

/// The horizontal direction the knees bend to (the body's front) from the
/// candidates that look like feet, or a zero vector when too few bend; each
/// leg's own bend (m) in `legs` when given.
Vec3 kneeBend(const PointGrid& g, const Geodesic& geo, const Extremities& ex, const TrunkFrame& tf,
              const Plane& floor, const BodyModel& model, std::vector<Vec3>* legs = nullptr);

/// Stage "body model": every joint placed from the trunk and the geodesic
/// paths (tip first) of the labelled extremities, with a confidence each.
struct BodyPose {
  Joints joints;
  std::array<float, NUM_JOINTS> confidence{};
  double torso_shift = 0;     ///< the head path's torso minus the trunk's, along up
};
BodyPose placeJoints(TrunkFrame tf, const std::array<std::vector<Vec3>, NUM_LABELS>& paths,
                     const std::array<Vec3, NUM_LABELS>& tips, const LabelAssignment& assign,
                     const BodyModel& model, const Vec3& lateral, const Joints* prev_mid);

/// Poses with one arm reaching to one of `tips`: for each arm whose hand
/// explains fewer than 5 depth points (`support`, a fit's), and each tip
/// within the arm's reach and 0.15 m or more from that hand, the pose `j`
/// with the hand about where placeJoints places one from a tip (5 cm back
/// towards the shoulder, 4 cm behind the surface) and the elbow
/// where both bones fit, bent as before. The tracker tries them from the
/// extremities no label took.
std::vector<Joints> armsToTips(const Joints& j, const std::array<int, NUM_JOINTS>& support,
                               const std::vector<Vec3>& tips, const BodyModel& model);

class ModelSearch;

struct TrackerParams {
  int grid_step = 0;          ///< 0: width / 160
  int calibration_frames = 15;
  int hold_frames = 10;       ///< how long a lost extremity is held
  JointFilterParams filter;   ///< each joint's filter (joint_filter.h)
  bool steady_depth = true;   ///< take each frame's depth shift out (DepthSteadier)
  double wall_hold = 2.0;     ///< margins a cell on a wall stays on it (wallCells; 1: no hold)
};

struct SkeletonEstimate {
  bool tracked = false;
  std::string state;          ///< searching, calibrating, tracking
  Joints joints;
  std::array<float, NUM_JOINTS> confidence{};
  int user_cells = 0;
  int extremities = 0;
  int labelled = 0;           ///< extremities taken for a head, hand or foot
  std::vector<Vec3> extremity_points;   ///< geodesic extrema found this frame
  double body_height = 0;     ///< the body model's calibrated height (m); 0 until calibrated
  double girth = 0;           ///< the body model's girth (BodyModel::girth); 0 until calibrated
};

class DepthTracker {
 public:
  explicit DepthTracker(const Camera& cam, TrackerParams params = TrackerParams());
  ~DepthTracker();
  /// One depth frame (millimetres) taken at time t (s, device clock).
  SkeletonEstimate update(const uint16_t* depth_mm, double t);
  /// The stages after segmentation on a user segmented elsewhere (the
  /// multi-user tracker's): the grid, the user and the room's floor.
  SkeletonEstimate follow(const PointGrid& g, const Segmentation& seg, const Plane& floor, double t);
  /// The user is not in this frame: the next frame starts from no previous pose
  /// (the bone lengths are kept).
  void lose();
  const BodyModel& model() const { return model_; }
  /// Times the facing check has turned the fitted pose round since the last reset.
  int facingTurns() const { return facing_turns_; }
  const Plane& floor() const { return floor_; }
  const std::vector<Plane>& walls() const { return room_.walls(); }
  void reset();

 private:
  /// Stage "segmentation": the room (floor and walls) and the user.
  Segmentation segment(const PointGrid& g);
  /// The bone lengths: calibrated on the first frames, then refined by the search.
  void calibrate(const PointGrid& g, const Segmentation& seg, const Joints& j, const LabelAssignment& assign);
  /// Stage "fit": the model fit refines this frame's estimate and last frame's
  /// pose; the one explaining the depth better wins. A hand it leaves unseen
  /// is tried at each of `spare_tips`, the extremities no label took.
  void fit(const PointGrid& g, const Segmentation& seg, const std::vector<Vec3>& spare_tips, Joints* j,
           std::array<float, NUM_JOINTS>* conf);
  /// Stage "facing": a fitted pose that both knees, bent the same way, say
  /// faces the other way (after a fast spin) has its left and right exchanged.
  void checkFacing(const std::vector<Vec3>& legs, const Vec3& up, Joints* j, std::array<float, NUM_JOINTS>* conf);
  /// Keeps every kRefitEvery-th fitted frame for the second bone-length search.
  void keepForRefit(const PointGrid& g, const Segmentation& seg);
  Joints smooth(const Joints& j, double t);
  LabelMemory memory() const;
  SkeletonEstimate follow(const PointGrid& g, const Segmentation& seg, double t);

  Camera cam_;
  TrackerParams params_;
  Room room_;
  DepthSteadier steadier_;
  Plane floor_;                 ///< the room's, or the multi-user tracker's
  BodyModel model_;
  std::vector<CalibrationSample> calib_;
  bool have_prev_ = false;
  Vec3 prev_centroid_;
  std::array<Vec3, NUM_LABELS> tips_;
  std::array<int, NUM_LABELS> tip_age_{};
  Vec3 lateral_{1, 0, 0};
  Vec3 facing_{1, 0, 0};        ///< smoothed lateral axis measured from the knees' bend
  int facing_votes_ = 0;        ///< frames in a row whose knees say the fitted pose faces the wrong way
  int facing_turns_ = 0;        ///< times the facing check turned the fitted pose round
  double torso_bias_ = 0;
  std::vector<FitFrame> calib_frames_;  ///< frames kept to fit the bone lengths
  std::unique_ptr<ModelSearch> search_;  ///< the bone-length search under way
  BodyModel target_;                      ///< the search's best, which model_ approaches
  /// Second search: frames kept once the first is over, each from its fitted
  /// pose (the first starts from rough poses and stops in their minimum).
  std::vector<FitFrame> refine_frames_;
  bool refined_ = false;
  int refit_count_ = 0;
  bool have_fit_ = false;
  Joints prev_fit_;             ///< last frame's fitted pose, before smoothing
  std::array<JointFilter, NUM_JOINTS> filters_;
};

}  // namespace hri_sync
