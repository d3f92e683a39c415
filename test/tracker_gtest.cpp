// Unit tests of the depth tracker's parts (segmentation, geodesic extremities,
// bone calibration, the model fit), the device clock mapping and the track loader, on depth
// rendered from the shared real motion (data/motion/cmu_60_01_salsa.track).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <stdexcept>

#include "hri_sync/body.h"
#include "hri_sync/clock_map.h"
#include "hri_sync/depth_tracker.h"
#include "hri_sync/pose_fit.h"
#include "hri_sync/render.h"

using namespace hri_sync;

namespace {

const std::string kMotion = std::string(HRI_SYNC_SOURCE_DIR) + "/data/motion/cmu_60_01_salsa.track";

const Track& motion() {
  static const Track t = Track::load(kMotion);
  return t;
}

std::vector<uint16_t> render(const Joints& j, const Camera& cam, bool background, bool body_only = false) {
  RenderOptions ro;
  ro.background = background;
  ro.noise = body_only ? 0.0 : 0.0015;
  if (body_only) ro.floor_y = -1e6;  // no floor: the body alone
  std::vector<uint16_t> d;
  renderDepth(j, cam, ro, &d);
  if (body_only) {  // the floor plane far away still returns: drop everything past the body
    for (auto& v : d) if (v > 6000) v = 0;
  }
  return d;
}

double boneLength(const Joints& j, Joint a, Joint b) { return (j[a] - j[b]).norm(); }

double meanError(const Joints& a, const Joints& b) {
  double e = 0;
  for (int k = 0; k < NUM_JOINTS; ++k) e += (a[k] - b[k]).norm();
  return e / NUM_JOINTS;
}

// One rendered frame of the motion as the tracker sees it, started from the
// true pose with every joint moved up to `shake` m at random.
FitFrame fitFrame(const Camera& cam, const Joints& truth, double shake, std::mt19937* rng) {
  std::vector<uint16_t> depth = render(truth, cam, false);
  FitFrame f;
  f.grid = makeGrid(depth.data(), cam, 2);
  f.floor = fitFloor(f.grid);
  f.seg = segmentUser(f.grid, f.floor, nullptr);
  std::uniform_real_distribution<double> u(-shake, shake);
  f.init = truth;
  for (Vec3& p : f.init) p += Vec3(u(*rng), u(*rng), u(*rng));
  return f;
}

}  // namespace

TEST(Track, RejectsMalformedLines) {
  char path[] = "/tmp/hri_sync_bad_trackXXXXXX";
  int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  FILE* f = fdopen(fd, "w");
  std::fprintf(f, "# comment\n0 1 2 3\n");
  std::fclose(f);
  try {
    Track::load(path);
    FAIL() << "a 4-number line was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(":2:"), std::string::npos) << e.what();
  }
  std::remove(path);
  EXPECT_THROW(Track::load("/nonexistent/x.track"), std::runtime_error);
}

TEST(Segmentation, FloorAndUserOnRealMotion) {
  Camera cam;
  const Track& m = motion();
  int n = 0;
  double iou_sum = 0;
  for (double t = 0.5; t < m.duration(); t += 1.0) {
    for (bool background : {false, true}) {
      Joints j = m.at(t, false);
      std::vector<uint16_t> depth = render(j, cam, background);
      PointGrid g = makeGrid(depth.data(), cam, 2);
      Plane floor = fitFloor(g);
      ASSERT_TRUE(floor.found) << "t=" << t;
      EXPECT_GT(floor.n.y, 0.995);
      EXPECT_NEAR(floor.d, 1.0, 0.03) << "the floor is y = -1";
      Segmentation seg = segmentUser(g, floor, nullptr);
      ASSERT_TRUE(seg.found) << "t=" << t << " background=" << background << ": " << seg.reason;
      // Truth: the cells where the body alone is what the sensor sees.
      std::vector<uint16_t> body = render(j, cam, false, true);
      int inter = 0, uni = 0;
      for (int y = 0; y < g.height; ++y) {
        for (int x = 0; x < g.width; ++x) {
          int i = y * g.width + x;
          int p = (y * 2 + 1) * cam.width + x * 2 + 1;
          bool truth = body[p] != 0 && std::abs(int(body[p]) - int(depth[p])) < 30 &&
                       floor.height(g.points[i]) > 0.05;
          inter += truth && seg.mask[i];
          uni += truth || seg.mask[i];
        }
      }
      double iou = uni ? double(inter) / uni : 0;
      EXPECT_GT(iou, 0.85) << "t=" << t << " background=" << background;
      iou_sum += iou;
      ++n;
    }
  }
  std::printf("segmentation: mean IoU %.3f over %d frames\n", iou_sum / n, n);
  EXPECT_GT(iou_sum / n, 0.95);
}

TEST(Geodesic, ExtremitiesReachHeadHandsFeet) {
  Camera cam;
  const Track& m = motion();
  int frames = 0, head = 0, feet = 0, hands = 0, hands_total = 0;
  for (double t = 0.25; t < m.duration(); t += 0.5) {
    Joints j = m.at(t, false);
    std::vector<uint16_t> depth = render(j, cam, false);
    PointGrid g = makeGrid(depth.data(), cam, 2);
    Segmentation seg = segmentUser(g, fitFloor(g), nullptr);
    ASSERT_TRUE(seg.found);
    Geodesic geo = geodesicExtremities(g, seg);
    ASSERT_GE(geo.extremities.size(), 3u);
    auto near = [&](const Vec3& p, double r) {
      for (int c : geo.extremities) if ((g.points[c] - p).norm() < r) return true;
      return false;
    };
    ++frames;
    head += near(j[HEAD], 0.25);
    feet += near(j[L_FOOT], 0.2) + near(j[R_FOOT], 0.2);
    // A hand is an extremity only when it is away from the body.
    for (Joint h : {L_HAND, R_HAND}) {
      if ((j[h] - j[TORSO]).norm() < 0.45) continue;
      ++hands_total;
      hands += near(j[h], 0.2);
    }
    // Each extremity's path leads back to the source.
    for (int c : geo.extremities) EXPECT_EQ(pathToSource(geo, c).back(), geo.source);
  }
  std::printf("extremities: head %d/%d, feet %d/%d, hands away from the body %d/%d\n", head, frames, feet,
              2 * frames, hands, hands_total);
  EXPECT_GE(double(head) / frames, 0.9);
  EXPECT_GE(double(feet) / (2 * frames), 0.9);
  ASSERT_GT(hands_total, 5);
  EXPECT_GE(double(hands) / hands_total, 0.8);
}

TEST(Calibration, BoneLengthsFromFirstFrames) {
  Camera cam;
  const Track& m = motion();
  DepthTracker tracker(cam);
  int n = 0;
  for (; n < 60 && !tracker.model().calibrated; ++n) {
    std::vector<uint16_t> depth = render(m.at(n / 30.0, false), cam, false);
    tracker.update(depth.data(), n / 30.0);
  }
  const BodyModel& b = tracker.model();
  ASSERT_TRUE(b.calibrated) << "not calibrated after " << n << " frames";
  const Joints& j0 = m.frames().front();
  double arm = boneLength(j0, L_SHOULDER, L_ELBOW) + boneLength(j0, L_ELBOW, L_HAND);
  double leg = boneLength(j0, L_HIP, L_KNEE) + boneLength(j0, L_KNEE, L_FOOT);
  std::printf("calibration after %d frames: height %.3f, arm %.3f (true %.3f), leg %.3f (true %.3f)\n", n,
              b.height, b.upper_arm + b.forearm, arm, b.thigh + b.shin, leg);
  EXPECT_NEAR(b.height, 1.70, 0.10);
  EXPECT_NEAR(b.upper_arm + b.forearm, arm, 0.2 * arm);
  EXPECT_NEAR(b.thigh + b.shin, leg, 0.2 * leg);
  EXPECT_NEAR(b.shoulder_width, boneLength(j0, L_SHOULDER, R_SHOULDER), 0.12);
}

TEST(PoseFit, PullsAShakenPoseBackOntoTheBody) {
  Camera cam;
  const Track& m = motion();
  std::mt19937 rng(3);
  BodyModel model = BodyModel::fromHeight(1.74);
  double before = 0, after = 0;
  int frames = 0;
  for (double t = 0.5; t < 16.0; t += 1.5, ++frames) {
    const Joints truth = m.at(t, false);
    FitFrame f = fitFrame(cam, truth, 0.08, &rng);
    ASSERT_TRUE(f.seg.found);
    PoseFit fit = PoseFitter(cam, f.grid, f.seg, f.floor, model).fit(f.init);
    before += meanError(f.init, truth);
    after += meanError(fit.joints, truth);
    EXPECT_GT(fit.support[TORSO], 20);
  }
  before /= frames;
  after /= frames;
  std::printf("pose fit over %d frames: mean joint error %.3f m shaken, %.3f m fitted\n", frames, before, after);
  EXPECT_LT(after, 0.07);
  EXPECT_LT(after, 0.6 * before);
}

TEST(Calibration, ModelSearchMovesTheLegsTowardsTheirLength) {
  Camera cam;
  const Track& m = motion();
  std::mt19937 rng(5);
  std::vector<FitFrame> frames;
  for (int k = 0; k < 6; ++k) frames.push_back(fitFrame(cam, m.at(0.2 + 0.1 * k, false), 0.03, &rng));
  const BodyModel start = BodyModel::fromHeight(1.74);
  ModelSearch search(cam, frames, start);
  int fits = 0;
  while (!search.advance(1)) ASSERT_LT(++fits, 2000) << "the search does not end";
  const Joints& j0 = m.frames().front();
  const double leg = boneLength(j0, L_HIP, L_KNEE) + boneLength(j0, L_KNEE, L_FOOT);
  const BodyModel& b = search.best();
  std::printf("model search: %d fits, leg %.3f -> %.3f (true %.3f)\n", fits, start.thigh + start.shin,
              b.thigh + b.shin, leg);
  EXPECT_LT(std::fabs(b.thigh + b.shin - leg), std::fabs(start.thigh + start.shin - leg));
}

TEST(DeviceClock, LowerEnvelopeFitsOffsetAndDrift) {
  // Device clock: 150 ppm fast, starts at 12.5 s; frames reach the host 2-40 ms late.
  std::mt19937 rng(3);
  std::exponential_distribution<double> late(1.0 / 0.008);
  DeviceClockMapper map;
  const double host0 = 1.7e9, drift = 150e-6;
  double worst = 0;
  for (int n = 0; n < 30 * 40; ++n) {
    double capture = host0 + n / 30.0;
    double device = 12.5 + (capture - host0) * (1 + drift);
    double arrival = capture + 0.002 + std::min(late(rng), 0.04);
    map.add(device, arrival);
    if (n > 30 * 10) worst = std::max(worst, std::fabs(map.toHost(device) - capture));
  }
  EXPECT_LT(worst, 0.004) << "mapped times off by up to " << worst << " s";
  EXPECT_NEAR(map.drift(), -drift, 30e-6);
  // A jump back (a recording that loops) starts the estimate over.
  EXPECT_FALSE(map.add(1.0, host0 + 100));
  EXPECT_FALSE(map.ready());
}

TEST(DeviceClock, GlobalClockModel) {
  GlobalClockModel c;
  c.ok = true;
  c.local_ref = 100;
  c.offset = 2.5;
  c.drift = 1e-4;
  EXPECT_DOUBLE_EQ(c.toGlobal(100), 102.5);
  EXPECT_NEAR(c.toGlobal(200), 200 + 2.5 + 0.01, 1e-9);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
