// Tests of the realistic virtual Kinect (issue 18): the Kinect v1 noise model
// (disparity quantization, projector shadow, holes, working range, seeding),
// body shapes that are not the tracker's fit model, tilted sensors, scene key
// errors, and the OpenNI2 driver rendering a still person in front of a wall
// with the floor under them, Kinect v1 noise on.
#include <gtest/gtest.h>

#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

#include "hri_sync/body.h"
#include "hri_sync/render.h"
#include "hri_sync/scene.h"

using namespace hri_sync;

namespace {

const std::string kMotion = std::string(HRI_SYNC_SOURCE_DIR) + "/data/motion/cmu_60_01_salsa.track";

const Track& motion() {
  static const Track t = Track::load(kMotion);
  return t;
}

// A person standing still in the motion's first pose.
Track stillTrack() {
  Joints j = motion().frames()[0];
  return Track::fromFrames({0.0, 10.0}, {j, j});
}

// Kinect v1 noise without the random part: quantization (and what else is asked) only.
KinectNoise exactNoise(bool shadow, bool holes) {
  KinectNoise n;
  n.enabled = true;
  n.speckle = false;
  n.disparity_sigma = 0.0;
  n.shadow = shadow;
  n.holes = holes;
  return n;
}

SceneOptions wallScene(double gap = 0.5) {
  SceneOptions o;
  o.wall_gap = gap;
  return o;
}

SceneFrame renderOnce(const Scene& s, uint64_t frame = 1) {
  Camera cam;
  SceneFrame f;
  s.render(0.0, frame, cam, &f);
  return f;
}

// Per image row crossing the person's torso: the width (pixels) of the run of
// missing depth just left (side = -1) or right (+1) of the person.
std::vector<int> shadowRuns(const SceneFrame& f, const Camera& cam, int side) {
  std::vector<int> runs;
  for (int v = 0; v < cam.height; ++v) {
    int first = -1, last = -1;
    for (int u = 0; u < cam.width; ++u) {
      if (f.label[v * cam.width + u] == LABEL_PERSON) {
        if (first < 0) first = u;
        last = u;
      }
    }
    if (first < 5 || last > cam.width - 6 || last - first < 15) continue;  // torso rows only
    int u = side < 0 ? first - 1 : last + 1, run = 0;
    while (u >= 0 && u < cam.width && f.depth_mm[v * cam.width + u] == 0 &&
           f.label[v * cam.width + u] == LABEL_WALL) {
      ++run;
      u += side;
    }
    runs.push_back(run);
  }
  return runs;
}

}  // namespace

TEST(KinectNoise, DepthStepGrowsWithTheSquareOfDistance) {
  KinectNoise n;
  for (double z : {1.0, 2.0, 4.0}) {
    EXPECT_NEAR(n.depthStep(z) / (std::fabs(n.c1) * z * z), 1.0, 0.03) << "at " << z << " m";
  }
  EXPECT_NEAR(n.depthStep(1.0), 0.00285, 0.0002);
  EXPECT_NEAR(n.depthStep(2.0), 0.0114, 0.0005);
  EXPECT_NEAR(n.depthStep(4.0), 0.0456, 0.002);
  // Khoshelham & Elberink 2012: about 7 cm between depth levels at 5 m.
  EXPECT_GT(n.depthStep(5.0), 0.06);
  EXPECT_LT(n.depthStep(5.0), 0.08);
}

TEST(KinectNoise, RenderedDepthsLieOnTheDisparityLattice) {
  SceneOptions o = wallScene(0.5);
  o.tilt_deg = 20;  // the wall's depth then varies along the image's columns
  o.sensor_height = 1.6;
  Scene s(stillTrack(), BodyShape::preset("average"), o, exactNoise(false, false));
  SceneFrame f = renderOnce(s);
  std::set<int> wall;
  int n = 0;
  for (size_t i = 0; i < f.depth_mm.size(); ++i) {
    int d = f.depth_mm[i];
    if (d == 0) continue;
    ++n;
    double lattice = s.noise().quantize(d / 1000.0) * 1000.0;
    ASSERT_LE(std::fabs(lattice - d), 0.51) << "pixel " << i << " reads " << d << " mm, off the lattice";
    if (f.label[i] == LABEL_WALL) wall.insert(d);
  }
  ASSERT_GT(n, 10000);
  ASSERT_GE(wall.size(), 5u);
  // Adjacent wall depths are one disparity step apart: |c1| z^2.
  int checked = 0;
  for (auto it = wall.begin(); std::next(it) != wall.end(); ++it) {
    double a = *it / 1000.0, b = *std::next(it) / 1000.0;
    EXPECT_NEAR(b - a, s.noise().depthStep(a), 0.0012 + 0.03 * s.noise().depthStep(a)) << "at " << a << " m";
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

TEST(KinectNoise, RandomErrorIsHalfADisparityStep) {
  // The independent model (noise=kinect1_iid), a still scene rendered many times:
  // the wall's depth spread is 0.5 |c1| z^2.
  Scene s(stillTrack(), BodyShape::preset("average"), wallScene(0.5), [] {
    KinectNoise n;
    n.enabled = true;
    n.speckle = false;
    n.disparity_sigma = 0.5;
    n.shadow = false;
    n.holes = false;
    return n;
  }());
  Camera cam;
  const size_t px = 5 * cam.width + 5;  // top-left corner: the wall
  std::vector<double> d;
  for (uint64_t k = 1; k <= 400; ++k) {
    SceneFrame f;
    s.render(0.0, k, cam, &f);
    ASSERT_EQ(f.label[px], LABEL_WALL);
    ASSERT_GT(f.depth_mm[px], 0);
    d.push_back(f.depth_mm[px] / 1000.0);
  }
  double mean = 0, var = 0;
  for (double x : d) mean += x;
  mean /= d.size();
  for (double x : d) var += (x - mean) * (x - mean);
  double sd = std::sqrt(var / (d.size() - 1)), model = 0.5 * s.noise().depthStep(mean);
  // Rounding to the lattice adds step^2/12 to the variance.
  double expected = std::sqrt(model * model + s.noise().depthStep(mean) * s.noise().depthStep(mean) / 12.0);
  EXPECT_NEAR(sd / expected, 1.0, 0.2) << "sd " << sd << " m at " << mean << " m";
}

namespace {

// The figures depth_noise_stats prints, on frames 1..T of a still scene: per-pixel
// temporal std in disparity units over wall pixels with a reading in every frame
// (> 2 px from a label edge), the spatial autocorrelation of their residuals along
// x, and the shares of pixels with no reading in any frame and of flickering ones.
struct NoiseFigures {
  double std_median = 0, std_p95 = 0, missing = 0, flicker = 0;
  std::vector<double> autocorr;  // lags 0..10
};

NoiseFigures measure(const Scene& s, const Camera& cam, int T) {
  const int W = cam.width, H = cam.height;
  const size_t N = static_cast<size_t>(W) * H;
  std::vector<SceneFrame> f(T);
  for (int t = 0; t < T; ++t) s.render(t / 30.0, t + 1, cam, &f[t]);
  const KinectNoise& n = s.noise();
  auto disp = [&](int mm) { return (1000.0 / mm - n.c0) / n.c1; };
  std::vector<uint8_t> use(N, 0);
  std::vector<double> mean(N, 0), sd;
  NoiseFigures out;
  for (int v = 2; v < H - 2; ++v) {
    for (int u = 2; u < W - 2; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      int reads = 0;
      for (int t = 0; t < T; ++t) reads += f[t].depth_mm[i] != 0;
      bool interior = true;
      for (int dv = -2; dv <= 2; ++dv)
        for (int du = -2; du <= 2; ++du) interior &= f[0].label[i + dv * W + du] == f[0].label[i];
      if (reads == 0) out.missing += 1;
      else if (reads < T) out.flicker += 1;
      if (reads != T || !interior || f[0].label[i] != LABEL_WALL) continue;
      use[i] = 1;
      double a = 0, b = 0;
      for (int t = 0; t < T; ++t) { double d = disp(f[t].depth_mm[i]); a += d; b += d * d; }
      mean[i] = a / T;
      sd.push_back(std::sqrt(std::max(0.0, (b - a * a / T) / (T - 1))));
    }
  }
  out.missing /= (W - 4) * (H - 4);
  out.flicker /= (W - 4) * (H - 4);
  std::sort(sd.begin(), sd.end());
  out.std_median = sd[sd.size() / 2];
  out.std_p95 = sd[static_cast<size_t>(0.95 * (sd.size() - 1))];
  std::vector<double> num(11, 0), cnt(11, 0);
  for (int t = 0; t < T; ++t) {
    for (size_t i = 0; i < N; ++i) {
      if (!use[i]) continue;
      const double r = disp(f[t].depth_mm[i]) - mean[i];
      for (int k = 0; k <= 10; ++k) {
        if (static_cast<int>(i % W) + k >= W || !use[i + k]) continue;
        num[k] += r * (disp(f[t].depth_mm[i + k]) - mean[i + k]);
        cnt[k] += 1;
      }
    }
  }
  for (int k = 0; k <= 10; ++k) out.autocorr.push_back((num[k] / cnt[k]) / (num[0] / cnt[0]));
  return out;
}

}  // namespace

// The real Kinect v1 clip (../shared/data/real_depth/kinect1_upper_body_close.oni,
// frames 8-15, depth_noise_stats --first 8), its wall at 2.7 m: temporal std 0.36
// disparity units median, 0.65 p95; residual autocorrelation along x 0.59, 0.38,
// 0.29, 0.22 at lags 1-4 px and 0.00 at 9 px (640x480). A still person before a
// wall, rendered with noise=kinect1 at 640x480, shows the same within the bounds
// below; the independent model (kinect1_iid) shows no spatial correlation.
TEST(KinectNoise, SpeckleMatchesTheRealClip) {
  Camera cam;
  cam.width = 640;
  cam.height = 480;
  SceneSpec spec;
  ASSERT_TRUE(applySceneKey("noise", "kinect1", &spec));
  Scene s(stillTrack(), BodyShape::preset("average"), wallScene(0.3), spec.noise);
  NoiseFigures m = measure(s, cam, 8);
  EXPECT_GT(m.std_median, 0.28);
  EXPECT_LT(m.std_median, 0.45);
  EXPECT_GT(m.std_p95, 0.50);
  EXPECT_LT(m.std_p95, 0.80);
  EXPECT_NEAR(m.autocorr[1], 0.59, 0.10);
  EXPECT_NEAR(m.autocorr[2], 0.38, 0.10);
  EXPECT_NEAR(m.autocorr[4], 0.22, 0.08);
  EXPECT_LT(std::fabs(m.autocorr[9]), 0.05);
  // Flicker: pixels reading in some frames only (real clip 4.8 %, the 3 m
  // recording 4 %), mostly at the person's outline and the shadow's border.
  EXPECT_GT(m.flicker, 0.015);
  EXPECT_LT(m.flicker, 0.08);

  SceneSpec iid;
  ASSERT_TRUE(applySceneKey("noise", "kinect1_iid", &iid));
  Scene si(stillTrack(), BodyShape::preset("average"), wallScene(0.3), iid.noise);
  NoiseFigures mi = measure(si, cam, 8);
  EXPECT_LT(std::fabs(mi.autocorr[1]), 0.05);
  EXPECT_LT(mi.flicker, m.flicker);
}

TEST(KinectNoise, ShadowFallsBesideNearEdgesAwayFromTheProjector) {
  Camera cam;
  for (double side : {1.0, -1.0}) {
    KinectNoise n = exactNoise(true, false);
    n.projector_x = side;
    Scene s(stillTrack(), BodyShape::preset("average"), wallScene(0.6), n);
    SceneFrame f = renderOnce(s);
    // Projector on +x (image right): the shadow is left of the person, and the reverse.
    std::vector<int> away = shadowRuns(f, cam, side > 0 ? -1 : 1);
    std::vector<int> toward = shadowRuns(f, cam, side > 0 ? 1 : -1);
    ASSERT_GT(away.size(), 40u);
    int away_rows = 0, toward_rows = 0;
    for (int r : away) away_rows += r > 0;
    for (int r : toward) toward_rows += r > 0;
    EXPECT_GT(away_rows, 0.8 * away.size()) << "projector " << side;
    EXPECT_LT(toward_rows, 0.1 * toward.size()) << "projector " << side;
    // Width: f b (1/z_person - 1/z_wall) pixels.
    std::vector<int> runs;
    for (int r : away) if (r > 0) runs.push_back(r);
    std::sort(runs.begin(), runs.end());
    Joints truth = s.truth(0);
    double fpx = cam.width / cam.xzFactor();
    double expect = fpx * n.baseline * (1.0 / truth[TORSO].z - 1.0 / s.wallZ());
    EXPECT_NEAR(runs[runs.size() / 2], expect, 2.0) << "projector " << side;
  }
  // Without the shadow, the wall meets the person on both sides.
  Scene flat(stillTrack(), BodyShape::preset("average"), wallScene(0.6), exactNoise(false, false));
  SceneFrame f = renderOnce(flat);
  for (int side : {-1, 1}) for (int r : shadowRuns(f, cam, side)) EXPECT_EQ(r, 0);
}

TEST(KinectNoise, SeededOutputIsReproducible) {
  KinectNoise n;
  n.enabled = true;
  Scene a(stillTrack(), BodyShape::preset("average"), wallScene(), n, nullptr, 7);
  Scene b(stillTrack(), BodyShape::preset("average"), wallScene(), n, nullptr, 7);
  Scene c(stillTrack(), BodyShape::preset("average"), wallScene(), n, nullptr, 8);
  EXPECT_EQ(renderOnce(a, 3).depth_mm, renderOnce(b, 3).depth_mm);
  EXPECT_NE(renderOnce(a, 3).depth_mm, renderOnce(a, 4).depth_mm);
  EXPECT_NE(renderOnce(a, 3).depth_mm, renderOnce(c, 3).depth_mm);
}

TEST(KinectNoise, WorkingRangeAndHolesOnDarkSurfaces) {
  KinectNoise n;
  n.enabled = true;
  SceneOptions o = wallScene(1.5);
  auto personHoles = [&](const char* body) {
    Scene s(stillTrack(), BodyShape::preset(body), o, n);
    SceneFrame f = renderOnce(s);
    int person = 0, holes = 0;
    for (size_t i = 0; i < f.depth_mm.size(); ++i) {
      int d = f.depth_mm[i];
      if (d != 0) {
        EXPECT_GE(d, n.min_range * 1000);
        EXPECT_LE(d, n.max_range * 1000);
      }
      if (f.label[i] == LABEL_PERSON) { ++person; holes += d == 0; }
    }
    return double(holes) / std::max(person, 1);
  };
  double light = personHoles("average"), dark = personHoles("dark_clothes");
  EXPECT_GT(dark, 2.0 * light) << "dark " << dark << " light " << light;
  EXPECT_GT(light, 0.0);   // grazing silhouette edges and the dark hair
  EXPECT_LT(light, 0.25);
}

TEST(BodyShape, PresetsKeepTheirHeightAndTheFeetOnTheFloor) {
  for (const std::string& name : BodyShape::presetNames()) {
    if (name == "model") continue;
    BodyShape shape = BodyShape::preset(name);
    BodyRig rig(motion(), shape);
    std::vector<double> tops;
    const double s = shape.height / 1.75;
    for (size_t i = 0; i < motion().size(); i += 5) {
      double t = motion().times()[i];
      Joints raw = motion().at(t), j = rig.pose(t);
      tops.push_back(j[HEAD].y + 0.145 * shape.height / rig.motionHeight() + 1.0);
      double before = std::min(raw[L_FOOT].y, raw[R_FOOT].y) + 1.0;
      double after = std::min(j[L_FOOT].y, j[R_FOOT].y) + 1.0;
      ASSERT_LE(std::fabs(after), std::fabs(before) * s * 1.3 + 0.01) << name << " at " << t;
    }
    std::sort(tops.begin(), tops.end());
    EXPECT_NEAR(tops[static_cast<size_t>(0.9 * (tops.size() - 1))], shape.height, 0.03) << name;
  }
}

TEST(BodyShape, ShapesAreNotTheFitModel) {
  // The same motion frame rendered as the fit model's capsules and as each shape: the
  // silhouettes differ by more than 15 % of the model's area (pixels in one, not the other).
  auto person = [&](const std::string& body) {
    Scene s(stillTrack(), BodyShape::preset(body), SceneOptions(), KinectNoise());
    SceneFrame f = renderOnce(s);
    std::vector<bool> m(f.label.size());
    for (size_t i = 0; i < m.size(); ++i) m[i] = f.label[i] == LABEL_PERSON;
    return m;
  };
  const std::vector<bool> model = person("model");
  const double area = std::count(model.begin(), model.end(), true);
  ASSERT_GT(area, 1000);
  for (const std::string& name : BodyShape::presetNames()) {
    if (name == "model") continue;
    std::vector<bool> m = person(name);
    int differ = 0;
    for (size_t i = 0; i < m.size(); ++i) differ += m[i] != model[i];
    EXPECT_GT(differ / area, 0.15) << name;
  }
  EXPECT_THROW(BodyShape::preset("giant"), std::invalid_argument);
  BodyShape tall = BodyShape::preset("average");
  tall.height = 2.3;
  EXPECT_THROW(BodyRig(motion(), tall), std::invalid_argument);
  BodyShape fit = BodyShape::preset("model");
  fit.girth = 1.2;  // the fit model's capsules cannot be reshaped
  EXPECT_THROW(fit.validate(), std::invalid_argument);
}

TEST(Scene, TiltedSensorSeesALevelFloorAndTheTruthMoves) {
  SceneOptions o;
  o.tilt_deg = 15;
  o.sensor_height = 1.5;
  Scene s(stillTrack(), BodyShape::preset("average"), o, KinectNoise());
  Camera cam;
  SceneFrame f = renderOnce(s);
  const double a = 15 * M_PI / 180;
  int floor = 0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      size_t i = v * cam.width + u;
      if (f.label[i] != LABEL_FLOOR || f.depth_mm[i] == 0) continue;
      Vec3 p = cam.toWorld(u, v, f.depth_mm[i] / 1000.0);
      double room_y = std::cos(a) * p.y - std::sin(a) * p.z + 1.5;
      ASSERT_NEAR(room_y, 0.0, 0.01) << "pixel " << u << "," << v;
      ++floor;
    }
  }
  EXPECT_GT(floor, 2000);
  // The truth is in the tilted sensor's frame: back in the room, it is the (reshaped) motion.
  Joints t = s.truth(0), room = BodyRig(stillTrack(), BodyShape::preset("average")).pose(0);
  for (int k = 0; k < NUM_JOINTS; ++k) {
    EXPECT_NEAR(std::cos(a) * t[k].y - std::sin(a) * t[k].z + 1.5, room[k].y + 1.0, 1e-9);
    EXPECT_NEAR(std::sin(a) * t[k].y + std::cos(a) * t[k].z, room[k].z, 1e-9);
  }
  for (int k = 0; k < NUM_JOINTS; ++k) {
    double u, v;
    cam.project(t[k], &u, &v);
    int iu = std::lround(u), iv = std::lround(v);
    if (iu < 0 || iu >= cam.width || iv < 0 || iv >= cam.height) continue;
    EXPECT_GT(f.depth_mm[iv * cam.width + iu], 0) << kJointNames[k];
  }
}

TEST(Scene, BystanderAndFurnitureAreLabelled) {
  SceneOptions o = wallScene(0.5);
  o.bystander = "stand";
  o.bystander_offset = -0.9;
  o.furniture = "table";
  Track walk = Track::load(std::string(HRI_SYNC_SOURCE_DIR) + "/data/motion/cmu_131_01_walk.track");
  Scene s(stillTrack(), BodyShape::preset("average"), o, KinectNoise(), &walk);
  SceneFrame f = renderOnce(s);
  EXPECT_TRUE(f.has_bystander);
  EXPECT_GT(std::count(f.label.begin(), f.label.end(), LABEL_BYSTANDER), 500);
  EXPECT_GT(std::count(f.label.begin(), f.label.end(), LABEL_FURNITURE), 300);
  EXPECT_GT(std::count(f.label.begin(), f.label.end(), LABEL_PERSON), 1000);
  EXPECT_NEAR(f.bystander_truth[TORSO].x - f.truth[TORSO].x, -0.9, 0.35);
  o.furniture = "none";
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), o, KinectNoise()), std::invalid_argument);
}

// The crowd (multi-user tests): crowd members stand at +s, -s, +2s beside the
// person, or walk their lanes in opposite directions; each has its truth and
// bystander-labelled pixels; bad crowd keys are refused.
TEST(Scene, CrowdStandsInARowOrWalksAcross) {
  Track walk = Track::load(std::string(HRI_SYNC_SOURCE_DIR) + "/data/motion/cmu_131_01_walk.track");
  SceneOptions o;
  o.crowd = 3;
  o.crowd_spacing = 0.8;
  Scene row(stillTrack(), BodyShape::preset("average"), o, KinectNoise(), &walk);
  SceneFrame f = renderOnce(row);
  EXPECT_FALSE(f.has_bystander);
  ASSERT_EQ(f.crowd_truth.size(), 3u);
  const double side[3] = {0.8, -0.8, 1.6};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(f.crowd_truth[c][TORSO].x - f.truth[TORSO].x, side[c], 0.25) << "crowd " << c + 1;
  }
  EXPECT_GT(std::count(f.label.begin(), f.label.end(), LABEL_BYSTANDER), 3 * 500);
  o = SceneOptions();
  o.bystander = "walk";
  o.crowd = 1;
  o.crowd_motion = "walk";
  Scene cross(stillTrack(), BodyShape::preset("average"), o, KinectNoise(), &walk);
  SceneFrame a, z;
  cross.render(0.5, 0, Camera(), &a);
  cross.render(7.5, 1, Camera(), &z);
  // The bystander walks towards +x, the crowd member towards -x, in a lane 0.9 m farther.
  EXPECT_GT(z.bystander_truth[TORSO].x - a.bystander_truth[TORSO].x, 1.0);
  EXPECT_LT(z.crowd_truth[0][TORSO].x - a.crowd_truth[0][TORSO].x, -1.0);
  SceneSpec spec;
  EXPECT_THROW(applySceneKey("crowd", "4", &spec), std::invalid_argument);
  EXPECT_THROW(applySceneKey("crowd", "1.5", &spec), std::invalid_argument);
  o.crowd_motion = "run";
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), o, KinectNoise(), &walk), std::invalid_argument);
  o.crowd_motion = "stand";
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), o, KinectNoise()), std::invalid_argument);
}

// crowd_tracks: each crowd member on its own track, placed as the person is
// (several sensors' views of one room): its truth follows its track, its
// pixels are rendered; a count that does not match is refused.
TEST(Scene, CrowdOnTheirOwnTracks) {
  Joints j = motion().frames()[0];
  std::vector<std::string> paths;
  for (const Vec3& d : {Vec3(1.0, 0, 0.5), Vec3(1.6, 0, -0.9)}) {
    Joints moved = j;
    for (Vec3& p : moved) p = p + d;
    paths.push_back("/tmp/virtual_kinect_gtest_crowd_" + std::to_string(getpid()) + "_" +
                    std::to_string(paths.size()) + ".track");
    FILE* f = std::fopen(paths.back().c_str(), "w");
    for (double t : {0.0, 10.0}) {
      std::fprintf(f, "%.1f", t);
      for (const Vec3& p : moved) std::fprintf(f, " %.4f %.4f %.4f", p.x, p.y, p.z);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  SceneSpec spec = parseSceneQuery("crowd_tracks=" + paths[0] + "," + paths[1]);
  EXPECT_EQ(spec.scene.crowd, 2);
  EXPECT_EQ(spec.scene.crowd_motion, "track");
  EXPECT_FALSE(spec.scene.needsWalk());
  Scene room(stillTrack(), BodyShape::preset("average"), spec.scene, KinectNoise());
  SceneFrame f = renderOnce(room);
  ASSERT_EQ(f.crowd_truth.size(), 2u);
  EXPECT_NEAR(f.crowd_truth[0][TORSO].x - f.truth[TORSO].x, 1.0, 0.05);
  EXPECT_NEAR(f.crowd_truth[0][TORSO].z - f.truth[TORSO].z, 0.5, 0.05);
  EXPECT_NEAR(f.crowd_truth[1][TORSO].x - f.truth[TORSO].x, 1.6, 0.05);
  EXPECT_NEAR(f.crowd_truth[1][TORSO].z - f.truth[TORSO].z, -0.9, 0.05);
  EXPECT_GT(std::count(f.label.begin(), f.label.end(), LABEL_BYSTANDER), 2 * 500);
  SceneOptions o = spec.scene;
  o.crowd = 1;
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), o, KinectNoise()), std::invalid_argument);
  o = SceneOptions();
  o.crowd = 1;
  o.crowd_motion = "track";
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), o, KinectNoise()), std::invalid_argument);
  EXPECT_THROW(parseSceneQuery("crowd_tracks=a,b,c,d"), std::invalid_argument);
  EXPECT_THROW(Scene(stillTrack(), BodyShape::preset("average"), parseSceneQuery("crowd_tracks=/nonexistent.track").scene,
                     KinectNoise()),
               std::runtime_error);
  for (const std::string& p : paths) std::remove(p.c_str());
}

TEST(Scene, BadKeysGiveClearErrors) {
  SceneSpec spec;
  auto message = [&](const char* k, const char* v) -> std::string {
    try {
      applySceneKey(k, v, &spec);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message("wall", "3").find("wall must be in [0.1, 1.5]"), std::string::npos);
  EXPECT_NE(message("tilt", "abc").find("bad value 'abc' for 'tilt'"), std::string::npos);
  EXPECT_NE(message("body", "giant").find("unknown body shape 'giant'"), std::string::npos);
  EXPECT_NE(message("shadow", "yes").find("(0 or 1)"), std::string::npos);
  EXPECT_NE(message("seed", "-1").find("seed"), std::string::npos);
  EXPECT_FALSE(applySceneKey("fps", "30", &spec));    // the driver's, not a scene key
  EXPECT_FALSE(applySceneKey("noise", "0.01", &spec));  // the capsule renderer's sigma
  EXPECT_TRUE(applySceneKey("noise", "kinect1", &spec));
  EXPECT_TRUE(spec.noise.enabled);
  spec.scene.tilt_deg = 30;
  EXPECT_THROW(spec.scene.validate(), std::invalid_argument);
}

// The driver, through OpenNI2: a still person, a wall 0.5 m behind, the floor
// under the feet, Kinect v1 noise on.
class VirtualKinectDriver : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { ASSERT_EQ(openni::OpenNI::initialize(), openni::STATUS_OK); }
  static void TearDownTestSuite() { openni::OpenNI::shutdown(); }
  void SetUp() override {
    char path[] = "/tmp/hri_sync_still_XXXXXX";
    int fd = mkstemp(path);
    ASSERT_GE(fd, 0);
    close(fd);
    track_path_ = std::string(path) + ".track";
    std::rename(path, track_path_.c_str());
    FILE* f = std::fopen(track_path_.c_str(), "w");
    ASSERT_NE(f, nullptr);
    Track still = stillTrack();
    for (size_t i = 0; i < still.size(); ++i) {
      std::fprintf(f, "%.4f", still.times()[i]);
      for (const Vec3& p : still.frames()[i]) std::fprintf(f, " %.6f %.6f %.6f", p.x, p.y, p.z);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  void TearDown() override { std::remove(track_path_.c_str()); }
  std::string track_path_;
};

// The first depth frame (320x240) of a virtual Kinect opened at uri, and its index.
void readFirstFrame(const std::string& uri, std::vector<uint16_t>* got, int* index) {
  openni::Device dev;
  ASSERT_EQ(dev.open(uri.c_str()), openni::STATUS_OK) << openni::OpenNI::getExtendedError();
  openni::VideoStream depth;
  ASSERT_EQ(depth.create(dev, openni::SENSOR_DEPTH), openni::STATUS_OK);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  openni::VideoFrameRef frame;
  ASSERT_EQ(depth.readFrame(&frame), openni::STATUS_OK);
  *index = frame.getFrameIndex();
  got->assign(static_cast<const uint16_t*>(frame.getData()),
              static_cast<const uint16_t*>(frame.getData()) + 320 * 240);
  depth.stop();
  depth.destroy();
  dev.close();
}

TEST_F(VirtualKinectDriver, RendersAStillPersonBeforeAWallWithKinectNoise) {
  const std::string query = "body=tall_slim&wall=0.5&noise=kinect1&seed=7";
  std::vector<uint16_t> got;
  int index = -1;
  ASSERT_NO_FATAL_FAILURE(readFirstFrame("virtual://" + track_path_ + "?" + query, &got, &index));

  // The same scene in-process, parsed from the same keys: the driver's frame is its render.
  SceneSpec spec;
  for (const char* kv : {"body=tall_slim", "wall=0.5", "noise=kinect1", "seed=7"}) {
    std::string s(kv);
    ASSERT_TRUE(applySceneKey(s.substr(0, s.find('=')), s.substr(s.find('=') + 1), &spec));
  }
  Track still = Track::load(track_path_);
  Scene scene(still, spec.body, spec.scene, spec.noise, nullptr, spec.seed);
  Camera cam;
  SceneFrame want;
  scene.render((index - 1) / 30.0, index, cam, &want);
  ASSERT_EQ(got, want.depth_mm);

  // And that render is the scene: the person at their depth, the floor under the feet,
  // the wall behind, a shadow beside the person, nothing outside 0.8-4 m.
  Joints truth = scene.truth(0);
  std::vector<double> person;
  int wall = 0, wall_ok = 0, shadow = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i]) {
      EXPECT_GE(got[i], 800);
      EXPECT_LE(got[i], 4000);
    }
    if (want.label[i] == LABEL_PERSON && got[i]) person.push_back(got[i] / 1000.0);
    if (want.label[i] == LABEL_WALL) {
      ++wall;
      if (got[i] && std::fabs(got[i] / 1000.0 - scene.wallZ()) < 3 * scene.noise().depthStep(scene.wallZ())) ++wall_ok;
      if (!got[i] && (i % 320) > 0 && want.label[i + 1] == LABEL_PERSON) ++shadow;
    }
  }
  ASSERT_GT(person.size(), 1500u);
  std::sort(person.begin(), person.end());
  EXPECT_NEAR(person[person.size() / 2], truth[TORSO].z, 0.15);
  EXPECT_GT(wall, 30000);
  EXPECT_GT(wall_ok, 0.9 * wall);
  EXPECT_GT(shadow, 0);
  for (int foot : {L_FOOT, R_FOOT}) {
    double u, v;
    cam.project(truth[foot], &u, &v);
    int iu = std::lround(u), below = 0, floor = 0;
    for (int iv = std::lround(v) + 1; iv < std::min(240, static_cast<int>(std::lround(v)) + 15); ++iv) {
      for (int du = -8; du <= 8; ++du) {
        size_t i = iv * 320 + std::clamp(iu + du, 0, 319);
        ++below;
        floor += want.label[i] == LABEL_FLOOR && got[i] > 0;
      }
    }
    EXPECT_GT(floor, 0.3 * below) << kJointNames[foot] << ": no floor under the foot";
  }
}

// hold=0 on the whole dance shows its first pose as a still .track of that pose
// shows it: distance and wall place the pose held, not the dance's mean and
// farthest position (which put this pose's hips at 4.17 m, beyond the 4 m range:
// nothing person-sized in view).
TEST_F(VirtualKinectDriver, HeldPoseIsPlacedAsAStillTrack) {
  const std::string query = "distance=3.5&wall=0.3&noise=kinect1";
  std::vector<uint16_t> got;
  int index = -1;
  ASSERT_NO_FATAL_FAILURE(readFirstFrame("virtual://" + kMotion + "?hold=0&" + query, &got, &index));

  SceneSpec spec = parseSceneQuery(query);
  Scene scene(stillTrack(), spec.body, spec.scene, spec.noise, nullptr, spec.seed);
  Camera cam;
  SceneFrame want;
  scene.render(0.0, index, cam, &want);
  ASSERT_EQ(got, want.depth_mm);
  std::vector<double> person;
  for (size_t i = 0; i < got.size(); ++i) {
    if (want.label[i] == LABEL_PERSON && got[i]) person.push_back(got[i] / 1000.0);
  }
  ASSERT_GT(person.size(), 800u);
  std::sort(person.begin(), person.end());
  EXPECT_NEAR(person[person.size() / 2], 3.5, 0.2);
}

// still_file: while the file exists the dancer stands still (every frame the pose
// at the motion's start, frames and noise going on); once it is gone the motion
// goes on from that pose, behind the frames' clock by the still time.
TEST_F(VirtualKinectDriver, DancerStandsStillWhileTheStillFileExists) {
  const std::string query = "noise=kinect1&seed=3";
  const std::string still_file = track_path_ + ".still";
  FILE* f = std::fopen(still_file.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fclose(f);
  openni::Device dev;
  ASSERT_EQ(dev.open(("virtual://" + kMotion + "?still_file=" + still_file + "&" + query).c_str()),
            openni::STATUS_OK) << openni::OpenNI::getExtendedError();
  openni::VideoStream depth;
  ASSERT_EQ(depth.create(dev, openni::SENSOR_DEPTH), openni::STATUS_OK);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  SceneSpec spec = parseSceneQuery(query);
  Scene scene(Track::load(kMotion), spec.body, spec.scene, spec.noise, nullptr, spec.seed);
  Camera cam;
  SceneFrame want;
  auto read = [&](int* index) {
    openni::VideoFrameRef frame;
    EXPECT_EQ(depth.readFrame(&frame), openni::STATUS_OK);
    *index = frame.getFrameIndex();
    return std::vector<uint16_t>(static_cast<const uint16_t*>(frame.getData()),
                                 static_cast<const uint16_t*>(frame.getData()) + 320 * 240);
  };
  int index = 0;
  for (int k = 0; k < 10; ++k) {  // a third of a second: still at the start's pose
    std::vector<uint16_t> got = read(&index);
    scene.render(0.0, index, cam, &want);
    ASSERT_EQ(got, want.depth_mm) << "frame " << index;
  }
  const int still_until = index;
  std::remove(still_file.c_str());
  std::vector<uint16_t> got;
  for (int k = 0; k < 10; ++k) got = read(&index);
  // Going on: the motion's time is (index - held) frames, held at least the still ones.
  bool found = false;
  for (int j = 1; j <= index - still_until && !found; ++j) {
    scene.render(j / 30.0, index, cam, &want);
    found = got == want.depth_mm;
  }
  EXPECT_TRUE(found) << "frame " << index << " is not the motion 1.." << index - still_until
                     << " frames after the still pose";
  depth.stop();
  depth.destroy();
  dev.close();
}

// epoch: the motion's time is the true time since epoch (so virtual Kinects
// opened at different moments, or on faked clocks, show one dancer at one
// instant): an epoch in the future shows the pose at start; one 5 s ago a
// pose about 5 s into the motion, whenever the device was opened.
TEST_F(VirtualKinectDriver, EpochSetsTheMotionsTimeByTheTrueClock) {
  const Track track = Track::load(kMotion);
  Camera cam;
  RenderOptions ro;
  ro.noise = 0.0;
  auto render = [&](double t) {
    std::vector<uint16_t> depth;
    renderDepth(track.at(t, true), cam, ro, &depth);
    return depth;
  };
  auto best_time = [&](const std::vector<uint16_t>& got) {  // the motion time it shows (10 ms steps)
    double best = -1.0, best_diff = 1e300;
    for (int k = 0; k <= 1000; ++k) {
      const std::vector<uint16_t> want = render(k * 0.01);
      double diff = 0.0;
      for (size_t i = 0; i < got.size(); ++i) diff += std::abs(static_cast<int>(got[i]) - want[i]);
      if (diff < best_diff) { best_diff = diff; best = k * 0.01; }
    }
    return best;
  };
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  const double unix_now = now.tv_sec + now.tv_nsec * 1e-9;
  std::vector<uint16_t> got;
  int index = -1;
  char query[64];
  std::snprintf(query, sizeof query, "?noise=0&start=1&epoch=%.3f", unix_now + 1000.0);
  ASSERT_NO_FATAL_FAILURE(readFirstFrame("virtual://" + kMotion + query, &got, &index));
  EXPECT_EQ(got, render(1.0)) << "an epoch to come shows the pose at start";
  std::snprintf(query, sizeof query, "?noise=0&epoch=%.3f", unix_now - 5.0);
  ASSERT_NO_FATAL_FAILURE(readFirstFrame("virtual://" + kMotion + query, &got, &index));
  const double shown = best_time(got);
  EXPECT_GE(shown, 4.99);
  EXPECT_LE(shown, 8.0) << "the first frame of a device opened now shows the motion 5 s in";
  ASSERT_NO_FATAL_FAILURE(readFirstFrame("virtual://" + kMotion + "?noise=0", &got, &index));
  EXPECT_LT(best_time(got), 1.0) << "without epoch the motion runs from the stream's start";
}

TEST_F(VirtualKinectDriver, BadSceneKeysFailToOpenWithTheReason) {
  struct Case { const char* query; const char* reason; };
  for (const Case& c : {Case{"wall=3", "wall must be in [0.1, 1.5]"},
                        Case{"bogus=1", "unknown URI key 'bogus'"},
                        Case{"body=giant", "unknown body shape 'giant'"},
                        Case{"wall=0.5&noise=0.01", "noise=SIGMA is the capsule renderer's"},
                        Case{"bystander=walk&bystander_track=/nonexistent.track", "/nonexistent.track"}}) {
    openni::Device dev;
    EXPECT_NE(dev.open(("virtual://" + track_path_ + "?" + c.query).c_str()), openni::STATUS_OK) << c.query;
    EXPECT_NE(std::string(openni::OpenNI::getExtendedError()).find(c.reason), std::string::npos)
        << c.query << ": " << openni::OpenNI::getExtendedError();
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
