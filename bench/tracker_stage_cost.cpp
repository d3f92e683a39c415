// tracker_stage_cost: CPU cost per frame of the depth tracker's segmentation
// parts (floor RANSAC, wall RANSAC, connected components, partial-view check)
// and of a whole DepthTracker::update, on a still person rendered by the
// virtual Kinect's scene (no OpenNI). Prints one JSON object (microseconds
// per call: median and p90 over the frames; the RANSAC fits run every 30th
// frame in the tracker, so their share per frame is also given).
//   tracker_stage_cost TRACK.track [SCENE_KEYS] [FRAMES]
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "hri_sync/depth_tracker.h"
#include "hri_sync/scene.h"

using namespace hri_sync;

namespace {

double cpuNow() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
}

template <typename F>
void timed(std::vector<double>* out, F f) {
  const double t0 = cpuNow();
  f();
  out->push_back(cpuNow() - t0);
}

std::string stat(const char* name, std::vector<double> v) {
  std::sort(v.begin(), v.end());
  char buf[160];
  std::snprintf(buf, sizeof buf, "\"%s\": {\"median_us\": %.0f, \"p90_us\": %.0f}", name, v[v.size() / 2],
                v[v.size() * 9 / 10]);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: tracker_stage_cost TRACK.track [SCENE_KEYS] [FRAMES]\n");
    return 2;
  }
  const Track motion = Track::load(argv[1]);
  SceneSpec spec;
  std::stringstream keys(argc > 2 ? argv[2] : "wall=0.3&noise=kinect1");
  for (std::string kv; std::getline(keys, kv, '&');) {
    const size_t eq = kv.find('=');
    if (kv.empty() || eq == std::string::npos || !applySceneKey(kv.substr(0, eq), kv.substr(eq + 1), &spec)) {
      std::fprintf(stderr, "tracker_stage_cost: bad scene key '%s' (%s)\n", kv.c_str(), sceneKeys());
      return 2;
    }
  }
  const int frames = argc > 3 ? std::max(10, std::atoi(argv[3])) : 150;
  Scene scene(motion, spec.body, spec.scene, spec.noise);
  Camera cam;
  DepthTracker tracker(cam);
  std::vector<double> grid_us, floor_us, walls_us, comp_us, partial_us, update_us;
  SceneFrame f;
  for (int i = 0; i < frames; ++i) {
    const double t = std::fmod(i / 30.0, std::max(motion.duration(), 1e-3));
    scene.render(t, i, cam, &f);
    PointGrid g;
    Plane floor;
    std::vector<Plane> walls;
    Segmentation seg;
    timed(&grid_us, [&] { g = makeGrid(f.depth_mm.data(), cam, 2); });
    timed(&floor_us, [&] { floor = fitFloor(g); });
    timed(&walls_us, [&] { walls = fitWalls(g, floor); });
    timed(&comp_us, [&] { seg = segmentUser(g, floor, nullptr, walls); });
    if (seg.found) timed(&partial_us, [&] { partialView(g, seg, floor); });
    timed(&update_us, [&] { tracker.update(f.depth_mm.data(), t); });
  }
  auto med = [](std::vector<double> v) { std::sort(v.begin(), v.end()); return v[v.size() / 2]; };
  std::printf("{\"frames\": %d, \"scene\": \"%s\", %s, %s, %s, %s, %s, %s, "
              "\"segmentation_per_frame_us\": %.0f}\n",
              frames, argc > 2 ? argv[2] : "wall=0.3&noise=kinect1", stat("grid", grid_us).c_str(),
              stat("floor_ransac", floor_us).c_str(), stat("wall_ransac", walls_us).c_str(),
              stat("components", comp_us).c_str(),
              stat("partial_view", partial_us.empty() ? std::vector<double>{0} : partial_us).c_str(),
              stat("update_total", update_us).c_str(),
              med(comp_us) + (med(floor_us) + med(walls_us)) / 30 + (partial_us.empty() ? 0 : med(partial_us)));
  return 0;
}
