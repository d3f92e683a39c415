// tracker_eval: renders a .track motion through the virtual Kinect (OpenNI2),
// runs the depth tracker on every frame and prints one JSON object with the
// error against the motion's true joints, the tracked share and the speed.
//   tracker_eval --track FILE.track [--res 320x240] [--seconds S] [--background 0|1]
//                [--noise SIGMA] [--scene KEY=V&KEY=V...] [--direct] [--step N] [--dump FILE]
//                [--snapshot N] [--users N] [--dump-users FILE] [--fps N]
//   tracker_eval --oni FILE.oni [--loops N] [--users N] [--dump FILE]
// --scene: the virtual Kinect's scene keys (body, wall, bystander, noise=kinect1, ...;
// docs/tracker.md); the truth is then the rendered (reshaped) body's joints.
// --snapshot N writes frame N's depth (uint16 mm) and pixel labels (uint8) to
// /tmp/tracker_snapshot.raw and /tmp/tracker_snapshot.label (direct mode).
// --step: depth pixels per tracker grid cell (default width / 160).
// --dump writes per frame: index, tracked, 15 estimated and 15 true joints, 15 confidences,
// the extremity count and the extremities.
// --dump-users (with --direct and --users N) writes per frame: index, the user count, per
// user its id, tracked, 15 estimated joints and 15 confidences, then the person count
// and each rendered person's 15 true joints (the person, the bystander, the crowd).
// --direct renders in-process instead of through OpenNI (same renderer); --fps N
// (with --direct) renders N frames a second of motion (default 30).
// --users N (1-4): the multi-user tracker the node runs (MultiTracker, N users at
// most), scored on the tracked user whose torso is nearest the person's (as a
// participant zone picks them); 0 (default): the single-user DepthTracker. With
// --direct it counts ghosts: users more than 0.7 m along the floor from every
// rendered person's torso.
// --oni plays a recording (every frame, N loops, default 4; its own field of view
// and device stamps) through the tracker: no truth, so it reports each frame's
// state, the users per frame (a recording of one person: more than one is a
// ghost), the frames with any leg joint of confidence > 0, and each joint's
// frame-to-frame motion p95 over consecutive published frames where it has
// confidence > 0; --dump as above with zero truth.
#include <OpenNI.h>

#include <algorithm>
#include <ctime>
#include <memory>
#include <set>
#include <stdexcept>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "hri_sync/body.h"
#include "hri_sync/depth_tracker.h"
#include "hri_sync/multi_tracker.h"
#include "hri_sync/oni_clip.h"
#include "hri_sync/render.h"
#include "hri_sync/scene.h"

using namespace hri_sync;

namespace {

// CPU time of this thread (s): the tracker's cost on one core, whatever else runs.
double threadCpu() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

struct Stats {
  std::vector<std::vector<double>> err = std::vector<std::vector<double>>(NUM_JOINTS);
  std::vector<double> hands_seen;  ///< hand errors where the tracker's confidence is >= 0.5
  int frames = 0, tracked = 0, dropped = 0;
  int facing_wrong = 0;  ///< tracked frames whose left-to-right axis points against the truth's
  int first_tracked = -1;  ///< frame index of the first tracked frame (calibration done)
  double cpu = 0;
};

double pct(std::vector<double> v, double q) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

FILE* g_dump = nullptr;
FILE* g_dump_users = nullptr;
int g_snapshot = -1;

void dumpJoints(FILE* f, const Joints& joints) {
  for (const Vec3& p : joints) std::fprintf(f, " %.4f %.4f %.4f", p.x, p.y, p.z);
}

// One --dump-users line: every user the tracker has, every rendered person's truth.
void dumpUsers(int index, const std::vector<UserEstimate>& users, const std::vector<Joints>& people) {
  std::fprintf(g_dump_users, "%d %zu", index, users.size());
  for (const UserEstimate& u : users) {
    std::fprintf(g_dump_users, " %u %d", u.user_id, u.estimate.tracked ? 1 : 0);
    dumpJoints(g_dump_users, u.estimate.joints);
    for (float c : u.estimate.confidence) std::fprintf(g_dump_users, " %.2f", c);
  }
  std::fprintf(g_dump_users, " %zu", people.size());
  for (const Joints& p : people) dumpJoints(g_dump_users, p);
  std::fprintf(g_dump_users, "\n");
}

void account(Stats* s, const SkeletonEstimate& est, const Joints& truth) {
  if (g_dump) {
    std::fprintf(g_dump, "%d %d", s->frames, est.tracked ? 1 : 0);
    dumpJoints(g_dump, est.joints);
    dumpJoints(g_dump, truth);
    for (float c : est.confidence) std::fprintf(g_dump, " %.2f", c);
    std::fprintf(g_dump, " %d", est.extremities);
    for (const Vec3& p : est.extremity_points) std::fprintf(g_dump, " %.4f %.4f %.4f", p.x, p.y, p.z);
    std::fprintf(g_dump, "\n");
  }
  ++s->frames;
  if (!est.tracked) return;
  if (s->first_tracked < 0) s->first_tracked = s->frames - 1;
  ++s->tracked;
  s->facing_wrong += rightToLeft(est.joints).dot(rightToLeft(truth)) < 0;
  for (int k = 0; k < NUM_JOINTS; ++k) s->err[k].push_back((est.joints[k] - truth[k]).norm());
  for (int k : {L_HAND, R_HAND})
    if (est.confidence[k] >= 0.5f) s->hands_seen.push_back(s->err[k].back());
}

// The tracker under test: the single-user DepthTracker or the multi-user one.
class Runner {
 public:
  Runner(const Camera& cam, const TrackerParams& params, int users) {
    if (users <= 0) {
      single_ = std::make_unique<DepthTracker>(cam, params);
      return;
    }
    MultiParams mp;
    mp.max_users = users;
    multi_ = std::make_unique<MultiTracker>(cam, params, mp);
  }
  /// The room's up in the sensor frame (a tilted sensor's), for ghost distances.
  void setUp(const Vec3& up) { up_ = up; }
  /// people: every rendered person's torso (the person, bystander, crowd), or
  /// null when they are not known (then no ghost is counted).
  SkeletonEstimate update(const uint16_t* depth, double t, const Joints& truth, const std::vector<Vec3>* people) {
    if (single_) return single_->update(depth, t);
    const MultiEstimate m = multi_->update(depth, t);
    last_ = m.users;
    users_ += m.tracked_users;
    last_users_ = static_cast<int>(m.users.size());
    // A user more than 0.7 m along the floor from every person's torso is a
    // ghost; heights are left out, as the tracker's association leaves them
    // out: a person half hidden behind another shows only their legs.
    for (const UserEstimate& u : m.users) {
      double nearest = 1e9;
      for (const Vec3& p : people ? *people : std::vector<Vec3>()) {
        const Vec3 d = u.centroid - p;
        nearest = std::min(nearest, (d - up_ * d.dot(up_)).norm());
      }
      if (people && nearest > 0.7) { ++ghost_frames_; ghost_ids_.insert(u.user_id); }
    }
    SkeletonEstimate best;
    best.state = m.state;
    double nearest = 1e9;
    for (const UserEstimate& u : m.users) {
      const double d = (u.estimate.joints[TORSO] - truth[TORSO]).norm();
      if (u.estimate.tracked && d < nearest) { nearest = d; best = u.estimate; }
    }
    return best;
  }
  double height() const { return single_ ? single_->model().height : -1.0; }
  /// The single-user tracker's facing turns as JSON; null for the multi-user one.
  std::string facingTurns() const { return single_ ? std::to_string(single_->facingTurns()) : "null"; }
  long trackedUsers() const { return users_; }  ///< summed over frames
  long ghostFrames() const { return ghost_frames_; }  ///< ghost users summed over frames
  size_t ghostUsers() const { return ghost_ids_.size(); }  ///< ids ever given to a ghost
  int lastUsers() const { return last_users_; }  ///< users (tracked or not) in the last frame
  const std::vector<UserEstimate>& users() const { return last_; }  ///< the last frame's users
  uint32_t idsIssued() const { return multi_ ? multi_->idsIssued() : 0; }

 private:
  std::unique_ptr<DepthTracker> single_;
  std::unique_ptr<MultiTracker> multi_;
  long users_ = 0;
  long ghost_frames_ = 0;
  std::set<uint32_t> ghost_ids_;
  int last_users_ = 0;
  std::vector<UserEstimate> last_;
  Vec3 up_{0, 1, 0};
};

// --oni: a recording through the tracker, loops times (see the header comment).
int runOni(const std::string& path, int loops, int users, const TrackerParams& params) {
  if (openni::OpenNI::initialize() != openni::STATUS_OK) {
    std::fprintf(stderr, "tracker_eval: OpenNI: %s\n", openni::OpenNI::getExtendedError());
    return 1;
  }
  DepthClip clip;
  if (!readOniClip(path, 0, &clip)) return 1;
  Camera cam;
  cam.width = clip.width;
  cam.height = clip.height;
  cam.setFov(clip.hfov, clip.vfov);
  Runner tracker(cam, params, users);
  Stats st;
  const size_t n = clip.frames.size();
  const double period = n > 1 ? (clip.stamps.back() - clip.stamps.front()) / (n - 1) : 1.0 / 30;
  const double span = clip.stamps.back() - clip.stamps.front() + period;
  std::vector<std::vector<double>> moves(NUM_JOINTS);
  std::string states;
  int max_users = 0, leg_frames = 0;
  SkeletonEstimate prev;
  const Joints zero{};
  for (int loop = 0; loop < loops; ++loop) {
    for (size_t f = 0; f < n; ++f) {
      const double t = clip.stamps[f] - clip.stamps.front() + loop * span;
      const SkeletonEstimate est = tracker.update(clip.frames[f].data(), t, zero, nullptr);
      account(&st, est, zero);
      max_users = std::max(max_users, tracker.lastUsers());
      bool legs = false;
      for (int k : {L_HIP, R_HIP, L_KNEE, R_KNEE, L_FOOT, R_FOOT}) legs |= est.tracked && est.confidence[k] > 0;
      leg_frames += legs;
      for (int k = 0; k < NUM_JOINTS && est.tracked && prev.tracked; ++k)
        if (est.confidence[k] > 0 && prev.confidence[k] > 0) moves[k].push_back((est.joints[k] - prev.joints[k]).norm());
      prev = est;
      if (loop == 0) states += std::string(f ? ", \"" : "\"") + est.state + "\"";
    }
  }
  std::string joints;
  for (int k = 0; k < NUM_JOINTS; ++k) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s\"%s\": %.4f", k ? ", " : "", kJointNames[k], pct(moves[k], 0.95));
    joints += buf;
  }
  std::printf("{\"oni\": \"%s\", \"frames\": %d, \"loops\": %d, \"period_s\": %.4f, \"tracked_share\": %.4f, "
              "\"frames_with_legs\": %d, \"max_users_in_a_frame\": %d, \"user_ids_issued\": %u, "
              "\"frame_to_frame_p95_m\": {%s}, \"states_first_loop\": [%s]}\n",
              path.c_str(), st.frames, loops, period, st.frames ? double(st.tracked) / st.frames : 0.0, leg_frames,
              max_users, tracker.idsIssued(), joints.c_str(), states.c_str());
  std::fflush(stdout);
  if (g_dump) std::fclose(g_dump);
  std::_Exit(st.frames > 0 ? 0 : 1);  // as oni_info: the file player can crash at teardown
}

}  // namespace

// Over 80 lines: a command-line driver (arguments, the frame loop, the JSON
// report) that reads best top to bottom; its parts are the library's.
int main(int argc, char** argv) {
  std::string track_path, res = "320x240";
  TrackerParams params;
  double seconds = 0, noise = 0.0015;
  std::string scene_query;
  bool direct = false, background = false;
  int users = 0, loops = 4, fps = 30;
  std::string oni;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) { std::fprintf(stderr, "tracker_eval: %s needs a value\n", a.c_str()); std::exit(2); }
      return argv[++i];
    };
    if (a == "--track") track_path = next();
    else if (a == "--res") res = next();
    else if (a == "--seconds") seconds = std::stod(next());
    else if (a == "--noise") noise = std::stod(next());
    else if (a == "--background") background = next() != "0";
    else if (a == "--scene") scene_query = next();
    else if (a == "--direct") direct = true;
    else if (a == "--step") params.grid_step = std::stoi(next());
    else if (a == "--filter-min-cutoff") params.filter.min_cutoff = std::stod(next());
    else if (a == "--filter-beta") params.filter.beta = std::stod(next());
    else if (a == "--filter-dead-zone") params.filter.dead_zone = std::stod(next());
    else if (a == "--snapshot") g_snapshot = std::stoi(next());
    else if (a == "--users") users = std::stoi(next());
    else if (a == "--dump") g_dump = std::fopen(next().c_str(), "w");
    else if (a == "--dump-users") g_dump_users = std::fopen(next().c_str(), "w");
    else if (a == "--oni") oni = next();
    else if (a == "--loops") loops = std::stoi(next());
    else if (a == "--fps") fps = std::stoi(next());
    else { std::fprintf(stderr, "tracker_eval: unknown argument %s\n", a.c_str()); return 2; }
  }
  if (!oni.empty()) {
    if (users < 0 || users > 4 || loops < 1) { std::fprintf(stderr, "tracker_eval: --users 0-4, --loops >= 1\n"); return 2; }
    return runOni(oni, loops, users, params);
  }
  if (track_path.empty()) { std::fprintf(stderr, "usage: tracker_eval --track FILE.track [...]\n"); return 2; }
  Track track;
  try {
    track = Track::load(track_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tracker_eval: %s\n", e.what());
    return 1;
  }
  if (seconds <= 0) seconds = track.duration();
  // The scene (when asked for): parsed as the driver parses it, so the truth is the rendered body's.
  SceneSpec spec;
  std::unique_ptr<Scene> scene;
  Track walk;
  try {
    spec = parseSceneQuery(scene_query);
    if (spec.used) {
      spec.scene.legacy_background = background;
      if (spec.scene.needsWalk()) {
        std::string wpath = spec.bystander_track;
        if (wpath.empty()) {
          size_t slash = track_path.rfind('/');
          wpath = (slash == std::string::npos ? std::string(".") : track_path.substr(0, slash)) + "/cmu_131_01_walk.track";
        }
        walk = Track::load(wpath);
      }
      scene = std::make_unique<Scene>(track, spec.body, spec.scene, spec.noise,
                                      spec.scene.needsWalk() ? &walk : nullptr, spec.seed);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tracker_eval: --scene: %s\n", e.what());
    return 2;
  }
  auto truthAt = [&](double t) { return scene ? scene->truth(t) : track.at(t); };
  Camera cam;
  cam.width = res == "640x480" ? 640 : 320;
  cam.height = res == "640x480" ? 480 : 240;
  if (fps != 30 && !direct) { std::fprintf(stderr, "tracker_eval: --fps needs --direct\n"); return 2; }
  if (fps < 1 || fps > 120) { std::fprintf(stderr, "tracker_eval: --fps 1-120\n"); return 2; }
  const int total = static_cast<int>(seconds * fps);
  if (users < 0 || users > 4) { std::fprintf(stderr, "tracker_eval: --users must be 0-4\n"); return 2; }
  if (g_dump_users && (users == 0 || !direct || !scene)) {
    std::fprintf(stderr, "tracker_eval: --dump-users needs --users N, --direct and --scene\n");
    return 2;
  }
  Runner tracker(cam, params, users);
  if (scene) tracker.setUp(scene->toSensor(Vec3(0, 1, 0)) - scene->toSensor(Vec3()));
  Stats st;

  if (direct) {
    std::vector<uint16_t> depth;
    RenderOptions ro;
    ro.background = background;
    ro.noise = noise;
    SceneFrame frame;
    for (int n = 0; n < total; ++n) {
      double t = static_cast<double>(n) / fps;
      Joints truth;
      if (scene) {
        scene->render(t, n + 1, cam, &frame);
        depth.swap(frame.depth_mm);
        truth = frame.truth;
      } else {
        truth = track.at(t);
        ro.seed = n + 1;
        renderDepth(truth, cam, ro, &depth);
      }
      if (n == g_snapshot) {
        FILE* f = std::fopen("/tmp/tracker_snapshot.raw", "wb");
        std::fwrite(depth.data(), 2, depth.size(), f);
        std::fclose(f);
        if (scene) {
          f = std::fopen("/tmp/tracker_snapshot.label", "wb");
          std::fwrite(frame.label.data(), 1, frame.label.size(), f);
          std::fclose(f);
        }
      }
      double c0 = threadCpu();
      std::vector<Vec3> people{truth[TORSO]};
      if (scene && spec.scene.bystander != "none") people.push_back(frame.bystander_truth[TORSO]);
      if (scene) for (const Joints& c : frame.crowd_truth) people.push_back(c[TORSO]);
      SkeletonEstimate est = tracker.update(depth.data(), t, truth, &people);
      st.cpu += threadCpu() - c0;
      if (g_dump_users) {
        std::vector<Joints> all{truth};
        if (spec.scene.bystander != "none") all.push_back(frame.bystander_truth);
        all.insert(all.end(), frame.crowd_truth.begin(), frame.crowd_truth.end());
        dumpUsers(st.frames, tracker.users(), all);
      }
      account(&st, est, truth);
    }
  } else {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) {
      std::fprintf(stderr, "tracker_eval: OpenNI: %s\n", openni::OpenNI::getExtendedError());
      return 1;
    }
    {
      char uri[4096];
      if (scene) {
        std::snprintf(uri, sizeof(uri), "virtual://%s?res=%s&background=%d&%s", track_path.c_str(), res.c_str(),
                      background ? 1 : 0, scene_query.c_str());
      } else {
        std::snprintf(uri, sizeof(uri), "virtual://%s?res=%s&noise=%g&background=%d", track_path.c_str(),
                      res.c_str(), noise, background ? 1 : 0);
      }
      openni::Device dev;
      openni::VideoStream depth;
      if (dev.open(uri) != openni::STATUS_OK || depth.create(dev, openni::SENSOR_DEPTH) != openni::STATUS_OK ||
          depth.start() != openni::STATUS_OK) {
        std::fprintf(stderr, "tracker_eval: cannot open %s: %s\n", uri, openni::OpenNI::getExtendedError());
        return 1;
      }
      openni::VideoFrameRef f;
      int last_index = 0;
      while (true) {
        openni::VideoStream* streams[] = {&depth};
        int ready;
        if (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 3000) != openni::STATUS_OK) {
          std::fprintf(stderr, "tracker_eval: no frame for 3 s\n");
          break;
        }
        if (depth.readFrame(&f) != openni::STATUS_OK) break;
        int idx = f.getFrameIndex();
        if (idx > total) break;
        if (last_index && idx > last_index + 1) st.dropped += idx - last_index - 1;
        last_index = idx;
        double t = (idx - 1) / static_cast<double>(fps);  // the virtual Kinect's motion time
        const Joints truth = truthAt(t);
        double c0 = threadCpu();
        SkeletonEstimate est = tracker.update(static_cast<const uint16_t*>(f.getData()), f.getTimestamp() * 1e-6, truth, nullptr);
        st.cpu += threadCpu() - c0;
        account(&st, est, truth);
      }
      depth.stop();
      depth.destroy();
      dev.close();
    }
    openni::OpenNI::shutdown();
  }

  std::vector<double> all;
  std::string joints;
  for (int k = 0; k < NUM_JOINTS; ++k) {
    all.insert(all.end(), st.err[k].begin(), st.err[k].end());
    double mean = 0;
    for (double e : st.err[k]) mean += e;
    mean = st.err[k].empty() ? -1 : mean / st.err[k].size();
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%s\"%s\": {\"mean_m\": %.4f, \"p95_m\": %.4f}", k ? ", " : "",
                  kJointNames[k], mean, pct(st.err[k], 0.95));
    joints += buf;
  }
  std::vector<double> hands = st.err[L_HAND];
  hands.insert(hands.end(), st.err[R_HAND].begin(), st.err[R_HAND].end());
  double mean = 0;
  for (double e : all) mean += e;
  mean = all.empty() ? -1 : mean / all.size();
  // Ghosts are counted where every person's truth is known: the multi-user tracker, rendered in-process.
  std::string ghost_frames = "null", ghost_rate = "null";
  if (users > 0 && direct && st.frames > 0) {
    ghost_frames = std::to_string(tracker.ghostFrames());
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", tracker.ghostUsers() / (st.frames / double(fps) / 60.0));
    ghost_rate = buf;
  }
  std::printf("{\"mean_error_m\": %.4f, \"joints\": {%s}, \"hands_p95_error_m\": %.4f, "
              "\"seen_hands_p95_error_m\": %.4f, \"seen_hands_share\": %.4f, \"tracked_share\": %.4f, "
              "\"tracked_share_after_calibration\": %.4f, \"first_tracked_frame\": %d, "
              "\"fps\": %.1f, \"frames\": %d, \"dropped_frames\": %d, \"resolution\": \"%dx%d\", "
              "\"height_m\": %.3f, \"body\": \"%s\", \"body_height_m\": %.3f, \"scene\": \"%s\", "
              "\"users\": %d, \"mean_tracked_users\": %.3f, \"ghost_user_frames\": %s, "
              "\"ghost_users_per_minute\": %s, \"facing_wrong_share\": %.4f, \"facing_turns\": %s}\n",
              mean, joints.c_str(), pct(hands, 0.95), pct(st.hands_seen, 0.95),
              hands.empty() ? 0.0 : double(st.hands_seen.size()) / hands.size(), st.frames ? double(st.tracked) / st.frames : 0.0,
              st.first_tracked >= 0 ? double(st.tracked) / (st.frames - st.first_tracked) : 0.0, st.first_tracked,
              st.cpu > 0 ? st.frames / st.cpu : 0.0, st.frames, st.dropped, cam.width, cam.height,
              tracker.height(), scene ? spec.body.name.c_str() : "model",
              scene ? spec.body.height : 0.0, scene_query.c_str(), users,
              st.frames ? double(tracker.trackedUsers()) / st.frames : 0.0, ghost_frames.c_str(), ghost_rate.c_str(),
              st.tracked ? double(st.facing_wrong) / st.tracked : 0.0, tracker.facingTurns().c_str());
  return st.frames > 0 ? 0 : 1;
}
