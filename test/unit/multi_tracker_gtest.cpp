// The tracker on virtual Kinect scenes. Several users: MultiTracker on scenes
// of 2, 3 and 4 people (the scene's crowd keys), each user's id checked frame
// by frame against the renderer's ground truth; the lost-user rule (same id
// back within lost_timeout, a new id after it); one user alone gives the
// single-user tracker's skeleton. Then a still person stays still (Kinect v1
// noise, walls, frame depth offsets), ghosts are no users, and a person first
// seen from behind or side-on is calibrated at its height, and a dancer who
// spins fast does not come out of it facing the wrong way round.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <unistd.h>

#include "hri_sync/depth_tracker.h"
#include "hri_sync/multi_tracker.h"
#include "hri_sync/scene.h"

using namespace hri_sync;

namespace {

const std::string kMotionDir = std::string(HRI_SYNC_SOURCE_DIR) + "/data/motion/";

const Track& salsa() {
  static const Track t = Track::load(kMotionDir + "cmu_60_01_salsa.track");
  return t;
}
const Track& walk() {
  static const Track t = Track::load(kMotionDir + "cmu_131_01_walk.track");
  return t;
}

// The salsa's first pose held for `seconds`.
Track still(double seconds) {
  std::vector<double> times;
  std::vector<Joints> frames;
  for (int i = 0; i * (1 / 30.0) <= seconds; ++i) { times.push_back(i / 30.0); frames.push_back(salsa().frames()[0]); }
  return Track::fromFrames(times, frames);
}

Scene makeScene(const Track& person, const std::string& keys) {
  SceneSpec spec;
  size_t pos = 0;
  while (pos < keys.size()) {
    size_t amp = keys.find('&', pos);
    const std::string item = keys.substr(pos, amp == std::string::npos ? std::string::npos : amp - pos);
    pos = amp == std::string::npos ? keys.size() : amp + 1;
    const size_t eq = item.find('=');
    if (!applySceneKey(item.substr(0, eq), item.substr(eq + 1), &spec)) throw std::invalid_argument(item);
  }
  return Scene(person, spec.body, spec.scene, spec.noise, &walk(), spec.seed);
}

// Who is who over a run: per person of the scene (0: the person, then the
// bystander, then the crowd), the user id tracked on them frame by frame
// (0: none within 0.35 m of their torso).
struct Ids {
  std::vector<std::vector<uint32_t>> ids;   // [person][frame]
  std::vector<std::vector<uint8_t>> in_view;  // [person][frame]: torso inside the image
  std::vector<int> tracked_users;            // per frame
  std::set<uint32_t> issued;
  int switches(size_t p) const {  // the id on p changed from one it had
    int n = 0;
    uint32_t last = 0;
    for (uint32_t id : ids[p]) {
      if (id && last && id != last) ++n;
      if (id) last = id;
    }
    return n;
  }
  double coverage(size_t p) const {  // share of frames in view with p tracked
    int seen = 0, tracked = 0;
    for (size_t f = 0; f < ids[p].size(); ++f) {
      seen += in_view[p][f];
      tracked += in_view[p][f] && ids[p][f];
    }
    return seen ? double(tracked) / seen : 0.0;
  }
  // Ids that were on two different people.
  int sharedIds() const {
    std::map<uint32_t, std::set<size_t>> on;
    for (size_t p = 0; p < ids.size(); ++p) for (uint32_t id : ids[p]) if (id) on[id].insert(p);
    int n = 0;
    for (auto& [id, people] : on) n += people.size() > 1;
    return n;
  }
};

bool inView(const Camera& cam, const Vec3& p) {
  if (p.z < 0.5) return false;
  double u, v;
  cam.project(p, &u, &v);
  return u >= 8 && v >= 8 && u < cam.width - 8 && v < cam.height - 8;
}

// Frames 0, stride, 2 stride, ... of the scene (stride > 1: a tracker that
// falls behind the sensor and drops frames).
Ids runScene(const Scene& scene, int frames, int max_users = 4, int stride = 1) {
  Camera cam;
  MultiParams mp;
  mp.max_users = max_users;
  MultiTracker tracker(cam, TrackerParams(), mp);
  Ids r;
  SceneFrame f;
  for (int n = 0; n < frames; ++n) {
    const double t = n * stride / 30.0;
    scene.render(t, n * stride, cam, &f);
    std::vector<Joints> truth{f.truth};
    if (f.has_bystander) truth.push_back(f.bystander_truth);
    truth.insert(truth.end(), f.crowd_truth.begin(), f.crowd_truth.end());
    r.ids.resize(truth.size());
    r.in_view.resize(truth.size());
    const MultiEstimate est = tracker.update(f.depth_mm.data(), t);
    r.tracked_users.push_back(est.tracked_users);
    if (std::getenv("MULTI_TRACKER_TRACE")) {  // per frame: users, their state and centroid
      std::printf("frame %d: %d in view, %d lost;", n, est.people_in_view, est.lost_users);
      for (const UserEstimate& u : est.users)
        std::printf(" [%u %s (%.2f %.2f %.2f)]", u.user_id, u.estimate.state.c_str(), u.centroid.x, u.centroid.y,
                    u.centroid.z);
      std::printf(" truth");
      for (const Joints& j : truth) std::printf(" (%.2f %.2f %.2f)", j[TORSO].x, j[TORSO].y, j[TORSO].z);
      std::printf("\n");
    }
    for (size_t p = 0; p < truth.size(); ++p) {
      uint32_t id = 0;
      double best = 0.35;
      for (const UserEstimate& u : est.users) {
        const double d = (u.estimate.joints[TORSO] - truth[p][TORSO]).norm();
        if (u.estimate.tracked && d < best) { best = d; id = u.user_id; }
      }
      r.ids[p].push_back(id);
      r.in_view[p].push_back(inView(cam, truth[p][TORSO]));
      if (id) r.issued.insert(id);
    }
  }
  return r;
}

void report(const char* what, const Ids& r) {
  std::printf("%s: %zu ids on people, %d shared;", what, r.issued.size(), r.sharedIds());
  for (size_t p = 0; p < r.ids.size(); ++p) {
    std::printf(" person %zu: coverage %.2f, switches %d, ids", p, r.coverage(p), r.switches(p));
    std::set<uint32_t> ids(r.ids[p].begin(), r.ids[p].end());
    for (uint32_t id : ids) if (id) std::printf(" %u", id);
    std::printf(";");
  }
  std::printf("\n");
}

}  // namespace

// Two people: the salsa dancer and a bystander who walks across the room 0.8 m
// behind them (passing behind the dancer, partly hidden). Each keeps one id.
TEST(MultiUser, TwoPeopleDancerAndWalkerBehind) {
  const Scene scene = makeScene(salsa(), "bystander=walk&bystander_offset=0.8");
  const Ids r = runScene(scene, 240);
  report("dancer + walker behind", r);
  EXPECT_EQ(r.sharedIds(), 0);
  for (size_t p = 0; p < 2; ++p) EXPECT_EQ(r.switches(p), 0) << "person " << p;
  EXPECT_GT(r.coverage(0), 0.8);  // measured 0.94 (the first ~20 frames calibrate)
  EXPECT_GT(r.coverage(1), 0.5);  // measured 0.64: the walker is hidden behind the dancer
}

// The salsa dancer between two people standing 1.3 m to either side of where
// they dance (the rostest tracker_multi_user's scene), a wall 0.5 m behind,
// Kinect v1 noise: three ids, none moved, also when the tracker sees only
// every third frame.
TEST(MultiUser, DancerBetweenTwoStandingPeople) {
  const Scene scene = makeScene(salsa(), "crowd=2&crowd_spacing=1.3&noise=kinect1&wall=0.5");
  for (int stride : {1, 3}) {  // 3: a tracker that falls behind and sees every third frame
    const Ids r = runScene(scene, 240 / stride, 4, stride);
    report(stride == 1 ? "dancer between two standing" : "dancer between two standing, every 3rd frame", r);
    EXPECT_EQ(r.sharedIds(), 0) << "stride " << stride;
    for (size_t p = 0; p < 3; ++p) {
      EXPECT_EQ(r.switches(p), 0) << "person " << p << ", stride " << stride;
      EXPECT_GT(r.coverage(p), 0.7) << "person " << p << ", stride " << stride;  // measured 0.94 / 0.81
    }
  }
}

// Two people walking past each other (opposite directions, lanes 0.6 m apart)
// in front of a still person, who is hidden as they pass: three ids, none
// swapped, none moved to another person.
TEST(MultiUser, TwoWalkersCrossInFrontOfAStillPerson) {
  const Scene scene = makeScene(still(9.0), "bystander=walk&bystander_offset=-1.3&crowd=1&crowd_motion=walk&crowd_spacing=0.6");
  const Ids r = runScene(scene, 240);
  report("two walkers crossing", r);
  EXPECT_EQ(r.sharedIds(), 0);
  for (size_t p = 0; p < 3; ++p) EXPECT_EQ(r.switches(p), 0) << "person " << p;
}

// A person who leaves the view (their pixels read no return) and comes back:
// after 2 s, the same id (within lost_timeout, 3 s); after 4 s, a new one.
TEST(MultiUser, LostUserKeepsItsIdWithinTheTimeout) {
  const Scene scene = makeScene(still(12.0), "wall=0.5");
  Camera cam;
  for (auto [gap, expect] : {std::pair<double, uint32_t>{2.0, 1}, {4.0, 2}}) {
    MultiTracker tracker(cam);
    SceneFrame f;
    std::vector<uint32_t> ids;
    int away = 0;
    for (int n = 0; n < 30 + static_cast<int>(gap * 30) + 30; ++n) {
      const double t = n / 30.0;
      scene.render(t, n, cam, &f);
      const bool gone = t >= 1.0 && t < 1.0 + gap;
      if (gone) {
        for (size_t i = 0; i < f.depth_mm.size(); ++i) if (f.label[i] == LABEL_PERSON) f.depth_mm[i] = 0;
      }
      const MultiEstimate est = tracker.update(f.depth_mm.data(), t);
      if (gone) away += est.users.empty() && est.lost_users == (gap < 3.0 || t < 4.0 ? 1 : 0);
      if (!gone && !est.users.empty()) ids.push_back(est.users[0].user_id);
      ASSERT_LE(est.users.size(), 1u) << "frame " << n;
    }
    std::printf("gap %.0f s: ids %u then %u (%d frames away as said)\n", gap, ids.front(), ids.back(), away);
    EXPECT_EQ(ids.front(), 1u);
    EXPECT_EQ(ids.back(), expect) << "gap " << gap;
    EXPECT_EQ(away, static_cast<int>(gap * 30)) << "gap " << gap;
  }
}

// Four people standing in a row 0.8 m apart, Kinect v1 noise: four users, four
// ids, each on one person for the whole run; with max_users 2, two users.
TEST(MultiUser, FourPeopleInARow) {
  const Scene scene = makeScene(still(3.0), "crowd=3&crowd_spacing=0.8&noise=kinect1");
  const Ids r = runScene(scene, 60);
  report("four in a row", r);
  EXPECT_EQ(r.sharedIds(), 0);
  EXPECT_EQ(r.issued.size(), 4u);
  for (size_t p = 0; p < 4; ++p) {
    EXPECT_EQ(r.switches(p), 0) << "person " << p;
    EXPECT_GT(r.coverage(p), 0.6) << "person " << p;  // the first ~20 frames calibrate
  }
  EXPECT_EQ(r.tracked_users.back(), 4);
  const Ids two = runScene(scene, 40, 2);
  EXPECT_EQ(two.tracked_users.back(), 2);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// A still person 0.3 m before a wall, on Kinect v1 noise as measured on a real
// recording (noise=kinect1), at 2.5 and 2.8 m: every joint's frame-to-frame
// motion p95 <= 1 cm, the expressiveness (the sum over joints of each
// joint's mean squared speed) <= 0.1 m^2/s^2 and the torso within 0.1 m of
// the truth in every tracked frame. The same frames through the
// one-euro filter the tracker had before (speed from one frame to the next,
// no dead zone) are not still at 2.8 m: the test sees a real sensor's failure.
namespace {

struct Stillness {
  double step_p95 = 0;       ///< m, any joint, frame to frame
  double expressiveness = 0; ///< m^2/s^2
  double trunk_expressiveness = 0;  ///< m^2/s^2 of head, neck, torso, shoulders and hips
  double torso_error = 0;    ///< m, the largest
  int frames = 0;
};

Stillness stillness(const Scene& scene, const TrackerParams& params, int frames) {
  Camera cam;
  DepthTracker tracker(cam, params);
  SceneFrame f;
  std::vector<Joints> out;
  std::vector<int> index;  // frame numbers of the tracked frames
  double torso_error = 0;
  for (int n = 0; n < frames; ++n) {
    scene.render(n / 30.0, n + 1, cam, &f);
    const SkeletonEstimate est = tracker.update(f.depth_mm.data(), n / 30.0);
    if (est.tracked) { out.push_back(est.joints); index.push_back(n); }
    if (est.tracked) torso_error = std::max(torso_error, (est.joints[TORSO] - f.truth[TORSO]).norm());
  }
  Stillness s;
  s.torso_error = torso_error;
  std::vector<double> steps;
  const size_t from = 30;  // the filter's first second
  for (size_t k = from + 1; k < out.size(); ++k) {
    const double dt = (index[k] - index[k - 1]) / 30.0;
    for (int j = 0; j < NUM_JOINTS; ++j) {
      const double d = (out[k][j] - out[k - 1][j]).norm();
      if (index[k] == index[k - 1] + 1) steps.push_back(d);
      s.expressiveness += d * d / dt;  // distance^2 / dt
      if (j <= R_SHOULDER || j == L_HIP || j == R_HIP) s.trunk_expressiveness += d * d / dt;
    }
  }
  if (steps.empty()) return s;
  s.frames = static_cast<int>(out.size() - from);
  s.expressiveness /= (index.back() - index[from]) / 30.0;  // over T
  s.trunk_expressiveness /= (index.back() - index[from]) / 30.0;
  std::sort(steps.begin(), steps.end());
  s.step_p95 = steps[steps.size() * 95 / 100];
  return s;
}

Track stillAt(double z) {  // salsa's first pose moved to z m from the sensor
  std::vector<double> times;
  std::vector<Joints> frames;
  Joints pose = salsa().frames()[0];
  const double shift = z - pose[TORSO].z;
  for (Vec3& p : pose) p.z += shift;
  for (int i = 0; i <= 600; ++i) { times.push_back(i / 30.0); frames.push_back(pose); }
  return Track::fromFrames(times, frames);
}

}  // namespace

TEST(StillPerson, IsStillThroughTheTrackerOnKinectNoise) {
  TrackerParams before;
  before.filter.min_cutoff = 4.0;
  before.filter.beta = 2.0;
  before.filter.dead_zone = 0.0;
  before.filter.block_s = 0.0;
  before.steady_depth = false;
  double worst_before = 0;
  for (double z : {2.5, 2.8}) {
    const Scene scene = makeScene(stillAt(z), "wall=0.3&noise=kinect1");
    const Stillness now = stillness(scene, TrackerParams(), 150);
    const Stillness old = z == 2.8 ? stillness(scene, before, 150) : Stillness();
    std::printf("still at %.1f m: p95 step %.4f m, expressiveness %.4f m^2/s^2, torso error %.3f m (%d frames); "
                "before: %.4f m, %.4f m^2/s^2\n", z, now.step_p95, now.expressiveness, now.torso_error, now.frames,
                old.step_p95, old.expressiveness);
    EXPECT_GT(now.frames, 90) << z;
    EXPECT_LE(now.step_p95, 0.01) << z;
    EXPECT_LE(now.expressiveness, 0.1) << z;
    EXPECT_LE(now.torso_error, 0.1) << z;
    worst_before = std::max(worst_before, old.expressiveness);
  }
  EXPECT_GT(worst_before, 0.1);  // the test sees a tracker that is not still
}

// A still person at 3.5 m, 0.3 m before a wall at the sensor's 4 m range:
// a Kinect v1 reads much of that wall as no return when the depth of a whole
// frame steps back, and the room's refit every 30 frames then misses the wall;
// the room keeps it (Room), so the person is never joined to the wall: the
// torso stays within 0.1 m of the truth and the trunk (head, neck, torso,
// shoulders, hips) is still. (The right hand, held forward, is found late at
// this distance and moves once onto the truth: docs/tracker.md.)
TEST(StillPerson, StaysApartFromAWallAtTheSensorsRange) {
  const Scene scene = makeScene(stillAt(3.5), "wall=0.3&noise=kinect1");
  const Stillness s = stillness(scene, TrackerParams(), 150);
  std::printf("still at 3.5 m: trunk expressiveness %.4f m^2/s^2, torso error %.3f m (%d frames)\n",
              s.trunk_expressiveness, s.torso_error, s.frames);
  EXPECT_GT(s.frames, 90);
  EXPECT_LE(s.torso_error, 0.1);
  EXPECT_LE(s.trunk_expressiveness, 0.1);
}

// A person at the sensor's range: the Kinect v1 reads nothing beyond 5 m, so a
// person 5.05 m away is cut by it, only what reaches nearer seen. The tracker
// makes no skeleton up for the rest (rangeCut: "too far / partial view"),
// where it followed the part seen with the whole body's confidence; a person at
// 3-4.5 m, or at 4 m with a wall 0.1 m behind, is never taken for one cut.
TEST(RangeCut, APersonBeyondTheSensorsRangeIsNotTracked) {
  for (auto [z, wall] : {std::pair<double, const char*>{3.0, ""}, {4.0, ""}, {4.5, ""}, {4.0, "wall=0.1&"},
                         {5.05, ""}}) {
    const Scene scene = makeScene(stillAt(z), std::string(wall) + "noise=kinect1");
    Camera cam;
    DepthTracker tracker(cam);
    SceneFrame f;
    int cut = 0, tracked = 0;
    std::string said;
    const int frames = 150;
    for (int n = 0; n < frames; ++n) {
      scene.render(n / 30.0, n + 1, cam, &f);
      const SkeletonEstimate est = tracker.update(f.depth_mm.data(), n / 30.0);
      if (est.state.rfind("too far / partial view: ", 0) == 0) {
        ++cut;
        said = est.state;
      }
      tracked += est.tracked;
    }
    std::printf("person at %.2f m%s: cut by the range in %d of %d frames, tracked in %d%s%s\n", z,
                wall[0] ? " (wall 0.1 m behind)" : "", cut, frames, tracked, said.empty() ? "" : "; the last: ",
                said.c_str());
    if (z > 5.0) {
      EXPECT_GE(cut, frames * 9 / 10) << z;
      EXPECT_LE(tracked, frames / 10) << z;
    } else {
      EXPECT_EQ(cut, 0) << z << wall;
      EXPECT_GE(tracked, frames / 2) << z << wall;
    }
  }
}

// People near walls: a still person with a wall 0.1 m behind at 2.5 m (the
// wall hides all but a strip of the floor) and 0.3 m behind at 3.5 m, Kinect
// v1 noise. Once the bone lengths are known (the last 5 s of 15), the head
// joint to the feet joints' midpoint is within 5 % of the truth's (measured
// -2.2 and -1.7 %; 7-10 % short before the head ball, the soles and the
// floor cue of the length search), and the torso within 0.1 m after the
// first second.
TEST(StillPerson, HeadToFootNearAWall) {
  for (auto [z, wall] : {std::pair<double, const char*>{2.5, "0.1"}, {3.5, "0.3"}}) {
    const Scene scene = makeScene(stillAt(z), std::string("wall=") + wall + "&noise=kinect1");
    Camera cam;
    DepthTracker tracker(cam);
    SceneFrame f;
    std::vector<double> ratio;
    double torso = 0;
    int tracked = 0;
    for (int n = 0; n < 450; ++n) {
      scene.render(n / 30.0, n + 1, cam, &f);
      const SkeletonEstimate est = tracker.update(f.depth_mm.data(), n / 30.0);
      if (!est.tracked || n < 30) continue;
      ++tracked;
      torso = std::max(torso, (est.joints[TORSO] - f.truth[TORSO]).norm());
      auto h2f = [](const Joints& j) { return (j[HEAD] - (j[L_FOOT] + j[R_FOOT]) * 0.5).norm(); };
      if (n >= 300) ratio.push_back(h2f(est.joints) / h2f(f.truth) - 1);
    }
    ASSERT_FALSE(ratio.empty()) << z;
    std::sort(ratio.begin(), ratio.end());
    const double median = ratio[ratio.size() / 2];
    std::printf("still at %.1f m, wall %s m behind: head-to-foot %+.1f %% of the truth, torso error %.3f m, "
                "tracked %d of 420 frames\n", z, wall, 100 * median, torso, tracked);
    EXPECT_LE(std::fabs(median), 0.05) << z;
    EXPECT_LE(torso, 0.1) << z;
    EXPECT_GT(tracked, 400) << z;
  }
}

// An arm held back against a wall: cmu_60_01's first pose, turned, holds its
// left hand and elbow within a few centimetres of a wall 0.1 m behind the
// back, where the Kinect v1's noise puts them on the wall in one frame and
// off it in the next. A cell on a wall stays on it within two margins
// (TrackerParams::wall_hold, wallCells), and an arm that explains no depth
// point keeps last frame's pose on its shoulder: at 2.5 m the person is
// still (measured 0.005 m^2/s^2). With no hold the wall's edge cells make
// and unmake that arm (0.26). At 3-4 m the arm still comes and goes in
// some runs (docs/tracker.md).
TEST(StillPerson, AnArmHeldBackAgainstAWall) {
  TrackerParams no_hold;
  no_hold.wall_hold = 1.0;
  const Scene scene = makeScene(stillAt(2.5), "wall=0.1&noise=kinect1");
  const Stillness now = stillness(scene, TrackerParams(), 300);
  const Stillness old = stillness(scene, no_hold, 300);
  std::printf("still at 2.5 m, wall 0.1 m behind: p95 step %.4f m, expressiveness %.4f m^2/s^2, torso error "
              "%.3f m (%d frames); no wall hold: %.4f m, %.4f m^2/s^2\n", now.step_p95, now.expressiveness,
              now.torso_error, now.frames, old.step_p95, old.expressiveness);
  EXPECT_GT(now.frames, 250);
  EXPECT_LE(now.step_p95, 0.01);
  EXPECT_LE(now.expressiveness, 0.1);
  EXPECT_LE(now.torso_error, 0.1);
  EXPECT_GT(old.expressiveness, 0.1);  // the test sees the arm come and go without the hold
}

// At 4 m the Kinect v1's depth steps (4.6 cm) make that arm the wall: it
// explains no point, and the fit laid its hand on the belly or the hip,
// whose points the trunk explains as well, and moved it from one to the other.
// Such points are no sign of an arm (PoseFitter: an arm's support counts only
// points no other part explains within the depth noise), so the arm is held.
TEST(StillPerson, AnArmHeldBackAgainstAWallFourMetresAway) {
  const Scene scene = makeScene(stillAt(4.0), "wall=0.1&noise=kinect1");
  const Stillness s = stillness(scene, TrackerParams(), 300);
  std::printf("still at 4 m, wall 0.1 m behind: p95 step %.4f m, expressiveness %.4f m^2/s^2, torso error %.3f m "
              "(%d frames)\n", s.step_p95, s.expressiveness, s.torso_error, s.frames);
  EXPECT_GT(s.frames, 250);
  EXPECT_LE(s.step_p95, 0.01);
  EXPECT_LE(s.expressiveness, 0.1);
  EXPECT_LE(s.torso_error, 0.1);
}

// A Kinect v1 shifts the inverse depth of a whole frame now and then (the
// scene's frame offsets: about once a second, 0.8 disparity steps, 2-3 cm at
// 3 m), and a tracker fitting the depth moves a still person with it. Taken
// out (TrackerParams::steady_depth, DepthSteadier), a still person 3 m away, 0.3 m
// before a wall, stays still: from 2 s to 8 s the torso's depth error varies
// by at most 6.5 mm (sd; 5.8 measured, 10.8 without) and that window's score
// is at most twice the score of its quietest second (the noise rule decides
// against 3 times a sensor's quietest second; 1.6 measured, 3.5 without).
// Without it the torso follows the offsets.
namespace {

struct StillRun {
  double torso_z_sd = 0;  ///< m
  double window = 0;      ///< m^2/s^2 over 2-8 s
  double quietest = 1e9;  ///< m^2/s^2 of the quietest whole second in 2-8 s
};

StillRun stillRun(const Scene& scene, const TrackerParams& params) {
  Camera cam;
  MultiTracker tracker(cam, params);
  SceneFrame f;
  std::vector<double> err, second(6, 0.0);
  Joints last;
  int last_n = -1;
  StillRun r;
  for (int n = 0; n < 240; ++n) {
    scene.render(n / 30.0, n + 1, cam, &f);
    const MultiEstimate est = tracker.update(f.depth_mm.data(), n / 30.0);
    if (est.users.empty() || !est.users[0].estimate.tracked || n < 60) continue;
    const Joints& j = est.users[0].estimate.joints;
    err.push_back(j[TORSO].z - f.truth[TORSO].z);
    if (last_n >= 0 && (last_n - 60) / 30 == (n - 60) / 30) {
      for (int k = 0; k < NUM_JOINTS; ++k) {
        const double d = (j[k] - last[k]).norm();
        second[(n - 60) / 30] += d * d / ((n - last_n) / 30.0);
      }
    }
    last = j;
    last_n = n;
  }
  double mean = 0, var = 0;
  for (double e : err) mean += e / err.size();
  for (double e : err) var += (e - mean) * (e - mean) / err.size();
  r.torso_z_sd = std::sqrt(var);
  for (double v : second) { r.window += v / 6.0; r.quietest = std::min(r.quietest, v); }
  EXPECT_GT(err.size(), 170u);
  return r;
}

}  // namespace

TEST(StillPerson, FrameDepthOffsetsDoNotMoveAStillPerson) {
  const Scene scene = makeScene(stillAt(3.0), "wall=0.3&noise=kinect1");
  TrackerParams off;
  off.steady_depth = false;
  const StillRun now = stillRun(scene, TrackerParams()), before = stillRun(scene, off);
  std::printf("still at 3 m: torso depth error sd %.4f m, 6 s score %.4f = %.2f x its quietest second; "
              "not steadied: %.4f m, %.4f = %.2f x\n", now.torso_z_sd, now.window, now.window / now.quietest,
              before.torso_z_sd, before.window, before.window / before.quietest);
  EXPECT_LE(now.torso_z_sd, 0.0065);
  EXPECT_LE(now.window, 2.0 * now.quietest);
  // The test sees a tracker that follows the offsets (and would win alone under the noise rule).
  EXPECT_GT(before.torso_z_sd, 0.009);
  EXPECT_GT(before.window, 3.0 * before.quietest);
}

// Users farther than 0.7 m along the floor from the person's torso (every
// user when the scene has no person), and the frames the person is tracked in.
struct GhostRun {
  int ghosts = 0, tracked = 0;
};
GhostRun ghostRun(const Scene& scene, int frames) {
  Camera cam;
  MultiTracker tracker(cam);
  SceneFrame f;
  GhostRun run;
  for (int n = 0; n < frames; ++n) {
    scene.render(n / 30.0, n + 1, cam, &f);
    const MultiEstimate m = tracker.update(f.depth_mm.data(), n / 30.0);
    for (const UserEstimate& u : m.users) {
      const Vec3 d = u.centroid - f.truth[TORSO];
      if (!scene.options().person || std::hypot(d.x, d.z) > 0.7) ++run.ghosts;
      run.tracked += u.estimate.tracked;
    }
  }
  return run;
}

// No ghosts: furniture at the edges of the view, the floor-wall seam, and an
// empty room with the same clutter never become users.
TEST(Ghosts, FurnitureAndSeamsAreNoUsers) {
  for (const char* keys : {"wall=0.3&furniture=chair&furniture_x=1.4&noise=kinect1",
                           "wall=0.3&furniture=table&furniture_x=-1.3&noise=kinect1",
                           "wall=0.2&furniture=chair&furniture_x=-0.9&noise=kinect1"}) {
    const GhostRun run = ghostRun(makeScene(stillAt(2.8), keys), 90);
    std::printf("%s: ghost user-frames %d, tracked %d of 90\n", keys, run.ghosts, run.tracked);
    EXPECT_EQ(run.ghosts, 0) << keys;
    EXPECT_GT(run.tracked, 60) << keys;
  }
}

// Clutter that is no person: a box, a person-sized flat board, a door-like
// slab, a curtain's folds, a coat on a stand (it passes the head and chest
// tests: it hangs with the view open below it) and the real recording's
// case, a small object in front of the wall 1.4 m beside a still person
// 0.3 m before the wall; at the left and right edges of the view, with the
// person in view and without.
TEST(Ghosts, ClutterIsNoUser) {
  for (const char* thing : {"box", "board", "door", "curtain", "coat_stand", "small_object"}) {
    for (const char* x : {"1.4", "-1.3"}) {
      for (const char* person : {"1", "0"}) {
        const std::string keys = std::string("person=") + person + "&wall=0.3&furniture=" + thing +
                                 "&furniture_x=" + x + "&noise=kinect1";
        const GhostRun run = ghostRun(makeScene(stillAt(2.8), keys), 45);
        std::printf("%s: ghost user-frames %d, tracked %d of 45\n", keys.c_str(), run.ghosts, run.tracked);
        EXPECT_EQ(run.ghosts, 0) << keys;
        if (person[0] == '1') {
          EXPECT_GT(run.tracked, 20) << keys;
        }
      }
    }
  }
}

// The bone lengths are calibrated on a user's first frames, from the head's
// height above the floor; a wrong head there shrinks the body for the whole
// session (every joint placed by lengths a quarter short). Two first poses,
// still, seen from behind and to the side, each of which did that on Kinect v1
// noise: cmu_60_01's turned 315 degrees, where a shoulder seen side-on was
// taken for the head and the head for a hand held up (calibrated 1.41 m), and
// cmu_61_01's turned 225 degrees, where the depth step between an arm held
// out and the waist cut the body in two and the legs alone were the user in
// half the frames (1.33 m). Now: the calibration's head is the top of the
// trunk's axis, and a body cut in two is both parts (stacked). The rendered
// body is 1.75 m; from the front the tracker calibrates 1.69 m.
namespace {

Track turnedStill(const Track& clip, double yaw_deg, double seconds) {
  const Joints first = clip.frames()[0];
  const Vec3 c = first[TORSO];
  const double a = yaw_deg * M_PI / 180;
  Joints pose;
  for (int k = 0; k < NUM_JOINTS; ++k) {
    const Vec3 d = first[k] - c;
    pose[k] = Vec3(std::cos(a) * d.x + std::sin(a) * d.z, first[k].y, 3.0 - std::sin(a) * d.x + std::cos(a) * d.z);
  }
  std::vector<double> times;
  std::vector<Joints> frames;
  for (int i = 0; i * (1 / 30.0) <= seconds; ++i) { times.push_back(i / 30.0); frames.push_back(pose); }
  return Track::fromFrames(times, frames);
}

// The single-user tracker's body model after `frames` frames of the scene.
BodyModel modelAfter(const Scene& scene, int frames) {
  Camera cam;
  DepthTracker tracker(cam);
  SceneFrame f;
  for (int n = 0; n < frames; ++n) {
    scene.render(n / 30.0, n + 1, cam, &f);
    tracker.update(f.depth_mm.data(), n / 30.0);
  }
  return tracker.model();
}

}  // namespace

TEST(Calibration, APersonSeenFromBehindAndSideOnGetsItsHeight) {
  static const Track other = Track::load(kMotionDir + "cmu_61_01_salsa.track");
  for (auto [clip, name, yaw] : {std::tuple<const Track*, const char*, double>{&salsa(), "cmu_60_01", 315.0},
                                 {&other, "cmu_61_01", 225.0}}) {
    const BodyModel model = modelAfter(makeScene(turnedStill(*clip, yaw, 3.0), "noise=kinect1"), 90);
    std::printf("%s's first pose turned %.0f degrees: calibrated %.3f m (body 1.75 m)\n", name, yaw, model.height);
    EXPECT_TRUE(model.calibrated) << name;
    EXPECT_NEAR(model.height, 1.75, 0.1) << name;
  }
}

// The model's trunk is the average adult's until the search measures the
// person's girth: a dancer rendered 1.4 times as broad in the trunk and thighs
// is fitted with a wider trunk than one rendered 0.8 times as broad.
TEST(Calibration, TheSearchMeasuresTheTrunksGirth) {
  const BodyModel broad = modelAfter(makeScene(salsa(), "girth=1.4&noise=kinect1"), 240);
  const BodyModel slim = modelAfter(makeScene(salsa(), "girth=0.8&noise=kinect1"), 240);
  std::printf("girth measured: %.3f (rendered 1.4), %.3f (rendered 0.8)\n", broad.girth, slim.girth);
  EXPECT_GT(broad.girth, 1.05);
  EXPECT_LT(slim.girth, 1.0);
}

// A taller person (tall_slim, 1.93 m) standing still 0.35 m behind a shorter
// one (short_broad, 1.55 m) shows head and shoulders above the shorter one's
// head, a part resting on its top: it is someone else, farther from the
// sensor, and joining it calibrated the shorter one at 1.25 m.
TEST(Calibration, ATallerPersonRightBehindIsNoPartOfTheUser) {
  const Track front = turnedStill(salsa(), 0.0, 4.0);
  const std::string path = "/tmp/multi_tracker_gtest_behind_" + std::to_string(getpid()) + ".track";
  FILE* out = std::fopen(path.c_str(), "w");
  ASSERT_NE(out, nullptr);
  for (double t : {0.0, 10.0}) {
    std::fprintf(out, "%.1f", t);
    for (const Vec3& p : front.frames()[0]) std::fprintf(out, " %.4f %.4f %.4f", p.x + 0.15, p.y, p.z + 0.35);
    std::fprintf(out, "\n");
  }
  std::fclose(out);
  const Scene scene = makeScene(front, "body=short_broad&noise=kinect1&crowd_tracks=" + path);
  std::remove(path.c_str());
  const BodyModel model = modelAfter(scene, 120);
  std::printf("a taller person 0.35 m behind: calibrated %.3f m (body 1.55 m)\n", model.height);
  EXPECT_TRUE(model.calibrated);
  EXPECT_NEAR(model.height, 1.55, 0.12);
}

// cmu_60_07's dancer spins with its back to the sensor at 10.7-11.5 s; the
// depth is the same seen from either side, and the fit, carried on from the
// last frame, came out of the spin facing the wrong way round and kept it to
// the clip's end (left and right exchanged: 98 frames of the first 14 s).
// Strong knee bends, which point forward, turn it back.
TEST(Facing, AFastSpinDoesNotLeaveTheDancerTurnedRound) {
  const Track clip = Track::load(kMotionDir + "cmu_60_07_salsa.track");
  const Scene scene = makeScene(clip, "noise=kinect1");
  Camera cam;
  DepthTracker tracker(cam);
  SceneFrame f;
  int wrong = 0, wrong_late = 0, tracked_late = 0;
  for (int n = 0; n < 14 * 30; ++n) {
    scene.render(n / 30.0, n + 1, cam, &f);
    const SkeletonEstimate est = tracker.update(f.depth_mm.data(), n / 30.0);
    if (!est.tracked) continue;
    const bool turned = rightToLeft(est.joints).dot(rightToLeft(f.truth)) < 0;
    wrong += turned;
    if (n >= 12 * 30) { wrong_late += turned; ++tracked_late; }
  }
  std::printf("facing wrong in %d frames, %d of the last 2 s's %d; turned back %d times\n", wrong, wrong_late,
              tracked_late, tracker.facingTurns());
  EXPECT_GT(tracked_late, 50);
  EXPECT_EQ(wrong_late, 0);
  EXPECT_LT(wrong, 40);
}
