// Virtual Kinect: an OpenNI2 driver that renders the depth image of a body
// (capsules around a skeleton's bones) moving as a .track file dictates.
//
// URI: virtual://PATH.track[?key=value&...]; keys (defaults):
//   res=320x240 (or 640x480), fps=30, background=0 (1: back wall and a cabinet),
//   noise=0.0015 (depth sigma in m at 1 m, grows with z^2; 0 turns it off),
//   loop=1 (0: stop sending frames at the end of the track), start=0 (s into the track),
//   hold=-1 (s into the track: the motion frozen at that time, a still person, whom the
//   scene keys distance and wall place as they place a still .track; -1: off),
//   offset_us=1000000 (device clock at open), drift_ppm=0 (device clock rate error),
//   lose_after=0 (s; > 0: the sensor is unplugged then: no more frames, a disconnect
//   event, and the device is announced again at once (replugged), so a reader that
//   reopens it gets a new device clock and the motion from its start),
//   unplug_file=PATH (unplugged as with lose_after as soon as PATH exists: a test
//   unplugs the sensor at a time of its choosing). A device is unplugged once: the
//   replugged one, opened again, stays.
//   still_file=PATH (while PATH exists the person stands still: the motion stops at
//   its pose, frames and noise go on, and it goes on from that pose once PATH is
//   gone; nodes/still_file makes PATH over the control module's calibration window).
//   epoch=-1 (true UNIX time, s, of the motion's time start: a frame shows the motion at
//   start + the true time since epoch, read by a raw clock_gettime system call that
//   libfaketime does not intercept, so virtual Kinects in processes of their own, each on
//   a faked clock, show one dancer at one instant; before epoch, the pose at start;
//   -1: the motion's time runs from the stream's start).
// Scene keys (docs/tracker.md, "Virtual Kinect scenes"): body=average|short_broad|tall_slim|
//   loose_clothes|dark_clothes|model, height, girth, limbs, arms, legs, clothing, clothes_albedo,
//   wall=GAP_M|none, furniture=none|table|chair, furniture_x, bystander=none|walk|stand,
//   bystander_offset, bystander_body, bystander_track=PATH, crowd=0..3, crowd_motion=stand|walk|track,
//   crowd_spacing, sensor_height, tilt (deg),
//   noise=kinect1, shadow, holes, baseline, projector=+x|-x, min_range, max_range, seed.
//   Any of them renders the scene (hri_sync::Scene) instead of the capsule body;
//   noise=SIGMA (Gaussian) is the capsule renderer's only and cannot be mixed with them.
// Setting HRI_SYNC_VIRTUAL_KINECT=URI also announces that device at start-up, so
// tools that open "any device" find it.
#define XN_NEW(type, ...) new type(__VA_ARGS__)
#define XN_DELETE(p) delete (p)
#include <Driver/OniDriverAPI.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include "hri_sync/body.h"
#include "hri_sync/render.h"
#include "hri_sync/scene.h"

namespace {

using hri_sync::Camera;
using hri_sync::RenderOptions;
using hri_sync::Track;
using Clock = std::chrono::steady_clock;

struct VirtualConfig {
  std::string uri, path;
  int width = 320, height = 240, fps = 30;
  RenderOptions render;
  bool loop = true;
  double start = 0.0, lose_after = 0.0, drift_ppm = 0.0;
  double hold = -1.0;           ///< >= 0: the motion frozen at this time (s)
  double offset_us = 1e6;
  double epoch = -1.0;          ///< >= 0: true UNIX time (s) of the motion's time start
  std::string unplug_file;      ///< unplugged when this file exists (empty: never)
  std::string still_file;       ///< the motion stands still while it exists
  hri_sync::SceneSpec scene;    ///< scene.used: render a Scene
  bool sigma_given = false;
};

/// The true UNIX time (s): a raw clock_gettime system call, which
/// libfaketime, interposed on the libc call, does not see.
double trueUnixTime() {
  timespec ts{};
  syscall(SYS_clock_gettime, CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + ts.tv_nsec * 1e-9;
}

double toNumber(const std::string& key, const std::string& value) {
  try {
    size_t pos = 0;
    double v = std::stod(value, &pos);
    if (pos != value.size()) throw std::invalid_argument(value);
    return v;
  } catch (const std::exception&) {
    throw std::runtime_error("virtual kinect: bad value '" + value + "' for '" + key + "'");
  }
}

VirtualConfig parseUri(const std::string& uri) {
  const std::string scheme = "virtual://";
  if (uri.compare(0, scheme.size(), scheme) != 0) {
    throw std::runtime_error("virtual kinect: URI must start with virtual://");
  }
  VirtualConfig c;
  c.uri = uri;
  c.render.noise = 0.0015;
  std::string rest = uri.substr(scheme.size());
  size_t q = rest.find('?');
  c.path = rest.substr(0, q);
  if (c.path.empty()) throw std::runtime_error("virtual kinect: URI has no track path");
  std::string query = q == std::string::npos ? "" : rest.substr(q + 1);
  std::stringstream ss(query);
  std::string item;
  while (std::getline(ss, item, '&')) {
    if (item.empty()) continue;
    size_t eq = item.find('=');
    if (eq == std::string::npos) throw std::runtime_error("virtual kinect: '" + item + "' is not key=value");
    std::string k = item.substr(0, eq), v = item.substr(eq + 1);
    try {
      if (hri_sync::applySceneKey(k, v, &c.scene)) continue;
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(std::string("virtual kinect: ") + e.what());
    }
    if (k == "res") {
      if (v == "320x240") { c.width = 320; c.height = 240; }
      else if (v == "640x480") { c.width = 640; c.height = 480; }
      else throw std::runtime_error("virtual kinect: res must be 320x240 or 640x480, not " + v);
    } else if (k == "fps") {
      c.fps = static_cast<int>(toNumber(k, v));
      if (c.fps != 30 && c.fps != 20 && c.fps != 15) throw std::runtime_error("virtual kinect: fps must be 15, 20 or 30");
    } else if (k == "background") { c.render.background = toNumber(k, v) != 0;
    } else if (k == "noise") { c.render.noise = toNumber(k, v); c.sigma_given = true;
    } else if (k == "loop") { c.loop = toNumber(k, v) != 0;
    } else if (k == "start") { c.start = toNumber(k, v);
    } else if (k == "hold") { c.hold = toNumber(k, v);
    } else if (k == "offset_us") { c.offset_us = toNumber(k, v);
    } else if (k == "drift_ppm") { c.drift_ppm = toNumber(k, v);
    } else if (k == "lose_after") { c.lose_after = toNumber(k, v);
    } else if (k == "unplug_file") { c.unplug_file = v;
    } else if (k == "still_file") { c.still_file = v;
    } else if (k == "epoch") { c.epoch = toNumber(k, v);
    } else {
      throw std::runtime_error("virtual kinect: unknown URI key '" + k + "' (keys: res, fps, background, noise, "
                               "loop, start, hold, offset_us, drift_ppm, lose_after, unplug_file, still_file, epoch, " +
                               hri_sync::sceneKeys() + ")");
    }
  }
  if (c.scene.used) {
    if (c.sigma_given && c.render.noise > 0) {
      throw std::runtime_error("virtual kinect: noise=SIGMA is the capsule renderer's; with scene keys use "
                               "noise=kinect1 or noise=0");
    }
    c.scene.scene.legacy_background = c.render.background;
    try {
      c.scene.scene.validate();
      c.scene.body.validate();
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(std::string("virtual kinect: ") + e.what());
    }
    if (c.scene.scene.needsWalk() && c.scene.bystander_track.empty()) {
      size_t slash = c.path.rfind('/');
      c.scene.bystander_track = (slash == std::string::npos ? std::string(".") : c.path.substr(0, slash)) +
                                "/cmu_131_01_walk.track";
    }
  }
  return c;
}

class VirtualDriver;

class DepthStream : public oni::driver::StreamBase {
 public:
  DepthStream(const VirtualConfig& cfg, std::shared_ptr<const Track> track,
              std::shared_ptr<const hri_sync::Scene> scene, std::function<void()> on_lost)
      : cfg_(cfg), track_(std::move(track)), scene_(std::move(scene)), on_lost_(std::move(on_lost)) {
    mode_.pixelFormat = ONI_PIXEL_FORMAT_DEPTH_1_MM;
    mode_.resolutionX = cfg.width;
    mode_.resolutionY = cfg.height;
    mode_.fps = cfg.fps;
  }
  ~DepthStream() override { stop(); }

  OniStatus start() override {
    if (running_) return ONI_STATUS_OK;
    running_ = true;
    thread_ = std::thread([this] { run(); });
    return ONI_STATUS_OK;
  }
  void stop() override {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  int getRequiredFrameSize() override { return mode_.resolutionX * mode_.resolutionY * 2; }

  OniBool isPropertySupported(int id) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: case ONI_STREAM_PROPERTY_STRIDE:
      case ONI_STREAM_PROPERTY_CROPPING: case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      case ONI_STREAM_PROPERTY_VERTICAL_FOV: case ONI_STREAM_PROPERTY_MAX_VALUE:
      case ONI_STREAM_PROPERTY_MIN_VALUE: case ONI_STREAM_PROPERTY_MIRRORING:
        return TRUE;
      default:
        return FALSE;
    }
  }

  OniStatus getProperty(int id, void* data, int* size) override {
    Camera cam;
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: return put(mode_, data, size);
      case ONI_STREAM_PROPERTY_STRIDE: return put<int>(mode_.resolutionX * 2, data, size);
      case ONI_STREAM_PROPERTY_CROPPING: {
        OniCropping c{};
        c.enabled = FALSE;
        c.width = mode_.resolutionX;
        c.height = mode_.resolutionY;
        return put(c, data, size);
      }
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: return put<float>(static_cast<float>(cam.hfov()), data, size);
      case ONI_STREAM_PROPERTY_VERTICAL_FOV: return put<float>(static_cast<float>(cam.vfov()), data, size);
      case ONI_STREAM_PROPERTY_MAX_VALUE: return put<int>(10000, data, size);
      case ONI_STREAM_PROPERTY_MIN_VALUE: return put<int>(0, data, size);
      case ONI_STREAM_PROPERTY_MIRRORING: return put<OniBool>(FALSE, data, size);
      default: return ONI_STATUS_NOT_SUPPORTED;
    }
  }

  OniStatus setProperty(int id, const void* data, int size) override {
    if (id == ONI_STREAM_PROPERTY_VIDEO_MODE && size == sizeof(OniVideoMode)) {
      const auto* m = static_cast<const OniVideoMode*>(data);
      bool ok = m->pixelFormat == ONI_PIXEL_FORMAT_DEPTH_1_MM &&
                ((m->resolutionX == 320 && m->resolutionY == 240) ||
                 (m->resolutionX == 640 && m->resolutionY == 480)) && m->fps == cfg_.fps;
      if (!ok || running_) return ONI_STATUS_NOT_SUPPORTED;
      mode_ = *m;
      return ONI_STATUS_OK;
    }
    if (id == ONI_STREAM_PROPERTY_MIRRORING && size == sizeof(OniBool)) {
      return *static_cast<const OniBool*>(data) ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    if (id == ONI_STREAM_PROPERTY_CROPPING && size == sizeof(OniCropping)) {
      return static_cast<const OniCropping*>(data)->enabled ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    return ONI_STATUS_NOT_SUPPORTED;
  }

 private:
  template <typename T>
  static OniStatus put(const T& v, void* data, int* size) {
    if (*size < static_cast<int>(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
    std::memcpy(data, &v, sizeof(T));
    *size = sizeof(T);
    return ONI_STATUS_OK;
  }

  void run() {
    Camera cam;
    cam.width = mode_.resolutionX;
    cam.height = mode_.resolutionY;
    const auto t0 = Clock::now();
    const double period = 1.0 / mode_.fps;
    std::vector<uint16_t> depth;
    hri_sync::SceneFrame scene_frame;
    uint64_t held = 0, last = 0;  // frame periods the motion stood still (still_file)
    for (uint64_t n = 0; running_; ++n) {
      const auto due = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(n * period));
      while (running_ && Clock::now() < due) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      if (!running_) break;
      // A real sensor captures on its own schedule: the frames whose time
      // passed while this thread could not run are lost (a gap in the frame
      // index), not delivered late in a burst, which would read as drift.
      const auto behind = static_cast<uint64_t>(std::chrono::duration<double>(Clock::now() - t0).count() / period);
      n = std::max(n, behind);
      const double elapsed = n * period;  // true time since the start (the frames' schedule)
      if ((cfg_.lose_after > 0 && elapsed >= cfg_.lose_after) ||
          (!cfg_.unplug_file.empty() && access(cfg_.unplug_file.c_str(), F_OK) == 0)) {
        if (on_lost_) on_lost_();
        while (running_) std::this_thread::sleep_for(std::chrono::milliseconds(20));
        break;
      }
      if (!cfg_.still_file.empty() && access(cfg_.still_file.c_str(), F_OK) == 0) held += n - last;
      last = n;
      const double run = cfg_.epoch >= 0 ? std::max(0.0, trueUnixTime() - cfg_.epoch) : n * period;
      double t = cfg_.hold >= 0 ? cfg_.hold : cfg_.start + run - held * period;
      if (!cfg_.loop && t > track_->duration()) {  // end of the motion: no more frames
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      if (scene_) {
        scene_->render(t, n + 1, cam, &scene_frame);
        depth.swap(scene_frame.depth_mm);
      } else {
        RenderOptions ro = cfg_.render;
        ro.seed = static_cast<uint32_t>(n + 1);
        hri_sync::renderDepth(track_->at(t, cfg_.loop), cam, ro, &depth);
      }
      OniFrame* frame = getServices().acquireFrame();
      if (frame == nullptr) continue;
      std::memcpy(frame->data, depth.data(), depth.size() * sizeof(uint16_t));
      frame->dataSize = static_cast<int>(depth.size() * sizeof(uint16_t));
      frame->sensorType = ONI_SENSOR_DEPTH;
      frame->frameIndex = static_cast<int>(n + 1);
      frame->timestamp = static_cast<uint64_t>(cfg_.offset_us + elapsed * 1e6 * (1.0 + cfg_.drift_ppm * 1e-6));
      frame->width = cam.width;
      frame->height = cam.height;
      frame->videoMode = mode_;
      frame->croppingEnabled = FALSE;
      frame->cropOriginX = 0;
      frame->cropOriginY = 0;
      frame->stride = cam.width * 2;
      raiseNewFrame(frame);
      getServices().releaseFrame(frame);
    }
  }

  VirtualConfig cfg_;
  std::shared_ptr<const Track> track_;
  std::shared_ptr<const hri_sync::Scene> scene_;  ///< null: the capsule renderer
  std::function<void()> on_lost_;
  OniVideoMode mode_;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

class VirtualDevice : public oni::driver::DeviceBase {
 public:
  VirtualDevice(VirtualConfig cfg, std::shared_ptr<const Track> track,
                std::shared_ptr<const hri_sync::Scene> scene, std::function<void()> on_lost)
      : cfg_(std::move(cfg)), track_(std::move(track)), scene_(std::move(scene)), on_lost_(std::move(on_lost)) {
    modes_[0] = {ONI_PIXEL_FORMAT_DEPTH_1_MM, 320, 240, cfg_.fps};
    modes_[1] = {ONI_PIXEL_FORMAT_DEPTH_1_MM, 640, 480, cfg_.fps};
    if (cfg_.width == 640) std::swap(modes_[0], modes_[1]);
    sensor_.sensorType = ONI_SENSOR_DEPTH;
    sensor_.numSupportedVideoModes = 2;
    sensor_.pSupportedVideoModes = modes_;
  }

  OniStatus getSensorInfoList(OniSensorInfo** infos, int* n) override {
    *infos = &sensor_;
    *n = 1;
    return ONI_STATUS_OK;
  }
  oni::driver::StreamBase* createStream(OniSensorType type) override {
    if (type != ONI_SENSOR_DEPTH) return nullptr;
    auto s = std::make_unique<DepthStream>(cfg_, track_, scene_, on_lost_);
    oni::driver::StreamBase* raw = s.get();
    streams_.push_back(std::move(s));
    return raw;
  }
  void destroyStream(oni::driver::StreamBase* stream) override {
    for (auto it = streams_.begin(); it != streams_.end(); ++it) {
      if (it->get() == stream) { streams_.erase(it); return; }
    }
  }

 private:
  VirtualConfig cfg_;
  std::shared_ptr<const Track> track_;
  std::shared_ptr<const hri_sync::Scene> scene_;
  std::function<void()> on_lost_;
  OniVideoMode modes_[2];
  OniSensorInfo sensor_;
  std::vector<std::unique_ptr<DepthStream>> streams_;
};

class VirtualDriver : public oni::driver::DriverBase {
 public:
  explicit VirtualDriver(OniDriverServices* services) : DriverBase(services) {}

  OniStatus initialize(oni::driver::DeviceConnectedCallback connected,
                       oni::driver::DeviceDisconnectedCallback disconnected,
                       oni::driver::DeviceStateChangedCallback state_changed, void* cookie) override {
    OniStatus s = DriverBase::initialize(connected, disconnected, state_changed, cookie);
    const char* env = std::getenv("HRI_SYNC_VIRTUAL_KINECT");
    if (s == ONI_STATUS_OK && env != nullptr && *env != '\0') tryDevice(env);
    return s;
  }

  OniStatus tryDevice(const char* uri) override {
    try {
      VirtualConfig cfg = parseUri(uri);
      makeScene(cfg, shown(cfg, load(cfg.path)));
    } catch (const std::exception& e) {
      if (std::strncmp(uri, "virtual://", 10) == 0) getServices().errorLoggerAppend("%s", e.what());
      return ONI_STATUS_ERROR;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (infos_.count(uri) == 0) {
      OniDeviceInfo info{};
      std::strncpy(info.uri, uri, ONI_MAX_STR - 1);
      std::strncpy(info.vendor, "hri_sync", ONI_MAX_STR - 1);
      std::strncpy(info.name, "Virtual Kinect", ONI_MAX_STR - 1);
      info.usbVendorId = 0x045e;  // the Kinect v1's ids, as a real device reports them
      info.usbProductId = 0x02ae;
      infos_[uri] = std::make_unique<OniDeviceInfo>(info);
      deviceConnected(infos_[uri].get());
    }
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    try {
      VirtualConfig cfg = parseUri(uri);
      auto track = shown(cfg, load(cfg.path));
      const std::string key = uri;
      const OniDeviceInfo* info = nullptr;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = infos_.find(uri);
        if (it != infos_.end()) info = it->second.get();
        if (unplugged_.count(key)) {  // the replugged device stays
          cfg.lose_after = 0.0;
          cfg.unplug_file.clear();
        }
      }
      auto on_lost = [this, info, key] {
        if (info == nullptr) return;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          unplugged_.insert(key);
        }
        deviceDisconnected(info);
        // Replugged at once: OpenNI forgets a disconnected device, so announce it
        // anew (with a fresh info; the old one stays alive for OpenNI).
        OniDeviceInfo* fresh = nullptr;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          auto copy = std::make_unique<OniDeviceInfo>(*info);
          fresh = copy.get();
          auto it = infos_.find(key);
          if (it != infos_.end()) retired_.push_back(std::move(it->second));
          infos_[key] = std::move(copy);
        }
        deviceConnected(fresh);
      };
      auto dev = std::make_unique<VirtualDevice>(cfg, track, makeScene(cfg, track), on_lost);
      oni::driver::DeviceBase* raw = dev.get();
      std::lock_guard<std::mutex> lock(mutex_);
      devices_.push_back(std::move(dev));
      return raw;
    } catch (const std::exception& e) {
      getServices().errorLoggerAppend("%s", e.what());
      return nullptr;
    }
  }

  void deviceClose(oni::driver::DeviceBase* device) override {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = devices_.begin(); it != devices_.end(); ++it) {
      if (it->get() == device) { devices_.erase(it); return; }
    }
  }

  void shutdown() override {
    std::lock_guard<std::mutex> lock(mutex_);
    devices_.clear();
  }

 private:
  /// The scene the URI asks for, or null (the capsule renderer). Throws on a bad scene.
  std::shared_ptr<const hri_sync::Scene> makeScene(const VirtualConfig& cfg, const std::shared_ptr<const Track>& track) {
    if (!cfg.scene.used) return nullptr;
    std::shared_ptr<const Track> walk;
    if (cfg.scene.scene.needsWalk()) walk = load(cfg.scene.bystander_track);
    try {
      return std::make_shared<const hri_sync::Scene>(*track, cfg.scene.body, cfg.scene.scene, cfg.scene.noise,
                                                     walk.get(), cfg.scene.seed);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(std::string("virtual kinect: ") + e.what());
    }
  }

  /// The motion the device shows: with hold, the one pose at that time held over
  /// the motion's span (a still person), so that a scene places that pose (distance,
  /// wall, body height) as it places a still .track, not the whole motion's range.
  static std::shared_ptr<const Track> shown(const VirtualConfig& cfg, std::shared_ptr<const Track> track) {
    if (cfg.hold < 0) return track;
    const hri_sync::Joints pose = track->at(cfg.hold, cfg.loop);
    return std::make_shared<const Track>(
        Track::fromFrames({track->times().front(), track->times().back()}, {pose, pose}));
  }

  std::shared_ptr<const Track> load(const std::string& path) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = tracks_.find(path);
    if (it != tracks_.end()) return it->second;
    auto t = std::make_shared<const Track>(Track::load(path));
    tracks_[path] = t;
    return t;
  }

  std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const Track>> tracks_;
  std::map<std::string, std::unique_ptr<OniDeviceInfo>> infos_;
  std::vector<std::unique_ptr<OniDeviceInfo>> retired_;
  std::set<std::string> unplugged_;  ///< URIs unplugged once (replugged: they stay)
  std::vector<std::unique_ptr<VirtualDevice>> devices_;
};

}  // namespace

ONI_EXPORT_DRIVER(VirtualDriver);
