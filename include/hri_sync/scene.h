// Realistic scenes for the virtual Kinect: body shapes that are not the
// tracker's fit model, a room (floor, wall, table or chair, a bystander), a
// tilted sensor at any height, and the Kinect v1 depth noise model.
// docs/tracker.md ("Virtual Kinect scenes") documents the model and its sources.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hri_sync/body.h"
#include "hri_sync/render.h"

namespace hri_sync {

/// A rendered body's shape. Heights and proportions reshape the motion's
/// joints (feet stay on the floor); girth and clothing widen the surface.
struct BodyShape {
  std::string name = "average";
  double height = 1.75;     ///< standing height, head top to floor (m), 1.5-1.95
  double girth = 1.0;       ///< torso, hips and thighs radius scale
  double limbs = 1.0;       ///< arm and shin radius scale
  double arms = 1.0;        ///< arm length scale (upper arm and forearm)
  double legs = 1.0;        ///< leg length scale (thigh and shin)
  double clothing = 0.0;    ///< loose clothing: surface offset on torso, arms, legs (m)
  double clothes_albedo = 0.6;  ///< infrared reflectance of the clothes (0..1; dark < 0.2)

  /// Named presets: average, short_broad, tall_slim, loose_clothes, dark_clothes.
  /// Throws std::invalid_argument on an unknown name.
  static BodyShape preset(const std::string& name);
  static std::vector<std::string> presetNames();
  /// Throws std::invalid_argument when a value is out of its documented range.
  void validate() const;
};

/// A motion retargeted to a body shape, in the track's frame (level sensor
/// 1 m above the floor, floor y = -1).
class BodyRig {
 public:
  BodyRig(const Track& track, const BodyShape& shape);
  /// The reshaped joints at time t (looped). These are the ground truth.
  Joints pose(double t) const;
  /// The surface: capsules with their reflectance (0..1).
  void capsules(const Joints& j, std::vector<Capsule>* caps, std::vector<double>* albedo) const;
  const BodyShape& shape() const { return shape_; }
  const Track& track() const { return track_; }
  /// The motion's own standing height before reshaping (m).
  double motionHeight() const { return motion_height_; }

 private:
  Joints proportion(const Joints& j) const;
  Track track_;
  BodyShape shape_;
  double motion_height_ = 1.75;
  double facing_sign_ = 1.0;
};

/// Kinect v1 depth noise (structured light, 11-bit disparity). The depth of a
/// disparity d is z = 1 / (c1 d + c0) (Khoshelham & Elberink 2012; Smisek et
/// al. 2011), so one disparity step is a depth step of |c1| z^2.
struct KinectNoise {
  bool enabled = false;
  double c1 = -2.85e-3;          ///< 1/m per disparity unit
  double c0 = 3.11;              ///< 1/m
  /// Random disparity error (units): sigma_z = sigma |c1| z^2. 0.3 with speckle (the
  /// real clip's wall); the independent model (speckle = false) uses 0.5.
  double disparity_sigma = 0.3;
  /// The real sensor's structure (docs/tracker.md, "Kinect v1 noise", measured on a real
  /// clip): false gives the independent per-pixel model (`noise=kinect1_iid`).
  bool speckle = true;
  /// Shares of the disparity error's variance correlated over fine_px and coarse_px
  /// (box windows, in 640x480 pixels, scaled to the image); the rest is per pixel.
  double fine_share = 0.4, fine_px = 5.0;
  double coarse_share = 0.6, coarse_px = 9.0;
  /// The error's sigma varies from place to place (static, lognormal with this
  /// log-sigma, in blobs of fine_px): some places of the dot pattern match worse.
  double sigma_spread = 0.5;
  /// A disparity offset of the whole frame (units, sigma), drawn anew with this
  /// probability per frame (the real depth steps now and then as a whole).
  double frame_offset_sigma = 0.8, frame_offset_jump = 1.0 / 30;
  /// Pixels within edge_px (640x480 pixels) of a depth edge or of the shadow read
  /// nothing with this probability per frame, in blobs of fine_px.
  double edge_px = 2.0, edge_drop = 0.5;
  /// Holes come in patches of hole_px (640x480 pixels); this share of the patch
  /// pattern stays from frame to frame, the rest is redrawn every frame.
  double hole_px = 5.0, hole_static_share = 0.6;
  bool shadow = true;            ///< projector shadow beside near edges
  double baseline = 0.075;       ///< projector-camera baseline (m)
  double projector_x = 1.0;      ///< +1: projector on the sensor's +x side, -1: -x side
  bool holes = true;             ///< dropouts on dark, far or grazing surfaces
  double min_range = 0.8;        ///< default mode 0.8 m (near mode 0.4-0.5 m)
  /// Beyond max_range reads 0. The specified working range ends at 4 m, but the
  /// sensor reads farther, more noisily (its error was measured to 5 m).
  double max_range = 5.0;

  /// The depth (m) a Kinect v1 reports for a true depth z, before random error.
  double quantize(double z) const;
  /// The depth step (m) between adjacent disparities at depth z.
  double depthStep(double z) const;
};

/// Where things are. The room frame: floor y = 0, z forward (level) from the
/// sensor's foot; the motion's track frame is the room seen from a level sensor
/// at 1 m (room = track + (0, 1, 0)).
struct SceneOptions {
  double sensor_height = 1.0;   ///< m above the floor (0.5-2)
  double tilt_deg = 0.0;        ///< sensor pitched down (0-20 deg)
  bool person = true;           ///< false: the room without the person (the truth still follows the motion)
  double wall_gap = -1.0;       ///< wall behind the person: m behind their back where the
                                ///< motion goes farthest (0.1-1.5); < 0: no wall
  double distance = -1.0;       ///< m from the sensor to the person's mean hip centre
                                ///< (1-5, along the floor); < 0: where the motion has them
  bool legacy_background = false;  ///< the old back wall at 4.5 m and a cabinet
  /// none, table, chair, box, board, door, curtain, coat_stand, small_object
  /// (docs/tracker.md, "Virtual Kinect scenes"): clutter that is no person.
  std::string furniture = "none";
  double furniture_x = 0.9;     ///< furniture centre, m right (+x) of the person's mean position
  std::string bystander = "none";  ///< none, walk (crosses the room), stand (stands beside)
  double bystander_offset = 0.8;   ///< walk: m behind (+) or in front (-) of the person;
                                   ///< stand: m to the side (+x right, -x left)
  BodyShape bystander_shape = BodyShape::preset("short_broad");
  int crowd = 0;                   ///< more people (0-3), on the bystander's track (multi-user tests)
  /// stand (in a row beside the person), walk (across the room) or track
  /// (each on its own track of crowd_tracks)
  std::string crowd_motion = "stand";
  double crowd_spacing = 0.9;      ///< stand: m between neighbours along x; walk: m between walking lanes
  /// crowd_motion track: crowd member c's .track file, its joints as they
  /// are in the person's track frame (moved with the person by distance):
  /// one room seen by several sensors, each given the tracks in its own frame.
  std::vector<std::string> crowd_tracks;
  /// Whether the scene needs the walk track (a bystander, or a crowd on it).
  bool needsWalk() const { return bystander != "none" || (crowd > 0 && crowd_motion != "track"); }
  /// Throws std::invalid_argument when a value is out of its documented range.
  void validate() const;
};

/// Pixel labels of a rendered frame: which surface the pixel's ray hits
/// (whether or not the noise model then drops its depth).
enum PixelLabel : uint8_t {
  LABEL_NONE = 0, LABEL_PERSON = 1, LABEL_BYSTANDER = 2, LABEL_FLOOR = 3, LABEL_WALL = 4,
  LABEL_FURNITURE = 5
};

/// One rendered frame with its ground truth.
struct SceneFrame {
  std::vector<uint16_t> depth_mm;  ///< 0 = no return
  std::vector<uint8_t> label;      ///< PixelLabel per pixel
  Joints truth;                    ///< the person's joints, sensor frame (OpenNI axes)
  bool has_bystander = false;
  Joints bystander_truth;          ///< the bystander's joints, sensor frame
  std::vector<Joints> crowd_truth; ///< the crowd's joints (SceneOptions::crowd), sensor frame
};

/// A scene: a person moving as a track, with a body shape, in a room, seen by
/// a (possibly tilted) Kinect v1. Deterministic for a given seed and frame.
class Scene {
 public:
  Scene(const Track& person, const BodyShape& shape, const SceneOptions& opt,
        const KinectNoise& noise, const Track* bystander_motion = nullptr, uint32_t seed = 1);
  /// Renders the frame at time t (s). frame_index seeds the noise.
  void render(double t, uint64_t frame_index, const Camera& cam, SceneFrame* out) const;
  /// The person's ground-truth joints at t, sensor frame.
  Joints truth(double t) const;
  /// Room -> sensor frame.
  Vec3 toSensor(const Vec3& room) const;
  double wallZ() const { return wall_z_; }
  const SceneOptions& options() const { return opt_; }
  const KinectNoise& noise() const { return noise_; }

 private:
  struct Box { Vec3 lo, hi; };
  struct Surfaces;
  void collect(double t, Surfaces* s, SceneFrame* out) const;
  /// The furniture's boxes (SceneOptions::furniture), after the wall is placed.
  void placeFurniture();

  BodyRig person_;
  /// The joints (room frame) of extra person k at t: the bystander (k = 0)
  /// when there is one, then the crowd.
  Joints extraPose(size_t k, double t) const;

  std::vector<BodyRig> bystander_;  ///< the bystander (if any), then the crowd
  SceneOptions opt_;
  KinectNoise noise_;
  uint32_t seed_;
  double wall_z_ = 0;
  Vec3 person_centre_;              ///< mean hip centre over the track, room frame
  Vec3 shift_;                      ///< added to the motion's positions (SceneOptions::distance)
  Vec3 walk_centre_;                ///< the walk motion's mean hip centre, track frame
  std::vector<Box> furniture_;
};

/// Everything a virtual Kinect URI's scene keys set (docs/tracker.md lists them).
struct SceneSpec {
  BodyShape body = BodyShape::preset("average");
  SceneOptions scene;
  KinectNoise noise;
  std::string bystander_track;  ///< "": cmu_131_01_walk.track beside the person's track
  uint32_t seed = 1;
  bool used = false;            ///< any scene key given: render with Scene, not renderDepth
};
/// Applies one URI key=value. Returns false when key is not a scene key;
/// throws std::invalid_argument naming the key on a bad value.
bool applySceneKey(const std::string& key, const std::string& value, SceneSpec* spec);
/// A scene from "key=value&key=value..." (the virtual Kinect URI's query);
/// std::invalid_argument naming a bad item and the valid keys.
SceneSpec parseSceneQuery(const std::string& query);
/// The scene keys, for error messages and docs.
const char* sceneKeys();

}  // namespace hri_sync
