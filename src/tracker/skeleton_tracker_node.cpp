// skeleton_tracker: OpenNI2 depth sensor or .oni recording in, global-time
// 15-joint hri_sync/Skeleton out on skeleton (relative: the node runs in its
// client's namespace NS/<client_id>/; remap it), status on /diagnostics.
//
// ~device      "" (first connected sensor), a URI (virtual://FILE.track?...), or FILE.oni
// ~backend     depth (default, the open tracker) or nite (libNiTE2.so at run time)
// ~client_id   the client whose clock (clock_state, relative) stamps the skeletons
// ~frame_id    header.frame_id (the sensor frame, OpenNI axes)
// ~loop        replay an .oni recording when it ends (default false)
//              (a recording starts playing once the global clock is ready:
//              before, its frames could only be withheld)
// ~frame_timeout  s without frames before the sensor is reported lost (1.0)
// ~reopen_period  s between attempts to reopen a lost or unopenable device (3.0)
// ~max_users   users tracked at once (depth backend, 1-4, default 4); each tracked
//              user is published with its own stable user_id (docs/tracker.md, "Several users")
// After a ROS master restart it ends with status 75 (include/hri_sync/master_watch.h)
// so that roslaunch's respawn registers it with the new master.
#include <OpenNI.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <diagnostic_msgs/DiagnosticStatus.h>
#include <hri_sync/ClockState.h>
#include <hri_sync/Skeleton.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <ros/xmlrpc_manager.h>

#include <atomic>
#include <cmath>
#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>

#include "hri_sync/clock_map.h"
#include "hri_sync/depth_tracker.h"
#include "hri_sync/master_watch.h"
#include "hri_sync/multi_tracker.h"
#include "hri_sync/nite_backend.h"

namespace hri_sync {
namespace {

// The local clock: CLOCK_REALTIME, the clock the CPM's time.time() reads (so a
// faketime of the client applies to both alike).
double localNow() { return ros::WallTime::now().toSec(); }

/// OpenNI's extended errors span lines and tabs: one line for logs and diagnostics.
std::string oneLine(const std::string& text) {
  std::istringstream words(text);
  std::string out, w;
  while (words >> w) out += (out.empty() ? "" : " ") + w;
  return out;
}

std::string fmt(double v, int prec = 3) {
  std::ostringstream ss;
  ss.setf(std::ios::fixed);
  ss.precision(prec);
  ss << v;
  return ss.str();
}

class TrackerNode : public openni::OpenNI::DeviceDisconnectedListener {
 public:
  TrackerNode() : pnh_("~") {
    pnh_.param<std::string>("device", device_uri_, "");
    pnh_.param<std::string>("backend", backend_name_, "depth");
    pnh_.param<std::string>("client_id", client_id_, "tracker");
    pnh_.param<std::string>("frame_id", frame_id_, "openni_depth_frame");
    pnh_.param("loop", loop_, false);
    pnh_.param("frame_timeout", frame_timeout_, 1.0);
    pnh_.param("reopen_period", reopen_period_, 3.0);
    pnh_.param("max_users", max_users_, 4);
    is_file_ = device_uri_.size() > 4 && device_uri_.compare(device_uri_.size() - 4, 4, ".oni") == 0;
    skeleton_pub_ = nh_.advertise<hri_sync::Skeleton>("skeleton", 30);
    diag_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
    // The same status, latched, for its client's CPM alone (it names what
    // the tracker says when the sensor falls silent).
    status_pub_ = pnh_.advertise<diagnostic_msgs::DiagnosticStatus>("sensor_status", 1, true);
    clock_sub_ = nh_.subscribe("clock_state", 1, &TrackerNode::onClock, this);
    diag_timer_ = nh_.createWallTimer(ros::WallDuration(1.0), &TrackerNode::publishDiagnostics, this);
    watcher_ = std::thread(&TrackerNode::watchMaster, this);
    if (backend_name_ != "depth" && backend_name_ != "nite") {
      setError("unknown ~backend '" + backend_name_ + "' (use depth or nite)");
      fatal_ = true;
    } else if (max_users_ < 1 || max_users_ > 4) {
      setError("~max_users must be 1 to 4, not " + std::to_string(max_users_));
      fatal_ = true;
    }
  }

  ~TrackerNode() override {
    stop_watch_ = true;
    if (watcher_.joinable()) watcher_.join();
    closeDevice();
  }

  /// Whether the node ended because the master restarted (exit kRestartExit).
  bool masterRestarted() const { return master_restarted_; }

  void onDeviceDisconnected(const openni::DeviceInfo* info) override {
    if (device_ && device_->isValid() && info && device_->getDeviceInfo().getUri() == std::string(info->getUri())) {
      lost_ = true;
    }
  }

  void run() {
    double last_attempt = -1e9;
    while (ros::ok()) {
      if (fatal_) { ros::WallDuration(0.2).sleep(); continue; }
      if (!depth_) {
        if (localNow() - last_attempt < reopen_period_) { ros::WallDuration(0.05).sleep(); continue; }
        if (is_file_ && !clockReady()) {  // a recording plays once: not into withheld frames
          ros::WallDuration(0.05).sleep();
          continue;
        }
        last_attempt = localNow();
        openDevice();
        continue;
      }
      if (nite_) {  // NiTE reads the device itself and blocks until its next frame
        handleFrame();
        continue;
      }
      openni::VideoStream* streams[] = {depth_.get()};
      int ready = -1;
      openni::Status st = openni::OpenNI::waitForAnyStream(streams, 1, &ready, 200);
      const double now = localNow();
      if (st != openni::STATUS_OK) {
        std::lock_guard<std::mutex> lock(mu_);
        double silent = now - (last_frame_local_ > 0 ? last_frame_local_ : opened_local_);
        if (ended()) {
          state_ = "end of recording";
        } else if (lost_ || silent > frame_timeout_) {
          setErrorLocked(std::string(lost_ ? "sensor disconnected" : "no depth frames") + " for " + fmt(silent, 1) +
                         " s: nothing published meanwhile (the gap shows in the stamps)");
          if (!is_file_ && silent > reopen_period_) {
            ROS_ERROR_STREAM("skeleton_tracker: " << error_ << "; reopening " << uriLabel());
            closeDeviceLocked();
          }
        }
        continue;
      }
      handleFrame();
    }
  }

 private:
  /// What the master has for node ``name``: whether it answered, and its URI.
  static MasterWatch::Answer lookupNode(const std::string& name) {
    XmlRpc::XmlRpcValue args, response, payload;
    args[0] = ros::this_node::getName();
    args[1] = name;
    MasterWatch::Answer a;
    bool known = ros::master::execute("lookupNode", args, response, payload, false);
    // false: no answer (response empty) or an error code (the node is unknown)
    a.answered = response.valid() && response.getType() == XmlRpc::XmlRpcValue::TypeArray && response.size() == 3;
    if (known && payload.getType() == XmlRpc::XmlRpcValue::TypeString) a.uri = static_cast<std::string>(payload);
    return a;
  }

  /// Asks the master every second whether it still knows this node; after a
  /// restart, writes the private params back for the respawned node and ends.
  void watchMaster() {
    MasterWatch watch(ros::this_node::getName(), ros::XMLRPCManager::instance()->getServerURI(), lookupNode);
    while (!stop_watch_ && ros::ok()) {
      for (int i = 0; i < 10 && !stop_watch_; ++i) ros::WallDuration(0.1).sleep();
      if (stop_watch_ || watch.check() != MasterWatch::State::Restarted) continue;
      ROS_ERROR_STREAM("skeleton_tracker: " << watch.reason() << "; ending with status " << kRestartExit
                                            << " for roslaunch to respawn it (without respawn, restart the launch)");
      pnh_.setParam("device", device_uri_);
      pnh_.setParam("backend", backend_name_);
      pnh_.setParam("client_id", client_id_);
      pnh_.setParam("frame_id", frame_id_);
      pnh_.setParam("loop", loop_);
      pnh_.setParam("frame_timeout", frame_timeout_);
      pnh_.setParam("reopen_period", reopen_period_);
      pnh_.setParam("max_users", max_users_);
      master_restarted_ = true;
      ros::shutdown();
      return;
    }
  }

  std::string uriLabel() const { return device_uri_.empty() ? "the first connected sensor" : "'" + device_uri_ + "'"; }

  bool clockReady() {
    std::lock_guard<std::mutex> lock(mu_);
    return clock_.ready;
  }

  bool ended() const {
    return is_file_ && !loop_ && total_frames_ > 0 && last_index_ >= total_frames_;
  }

  void onClock(const hri_sync::ClockState::ConstPtr& msg) {
    ClockStatus c = clockStatus(*msg);
    std::lock_guard<std::mutex> lock(mu_);
    clock_ = c;
  }

  void setError(const std::string& e) { std::lock_guard<std::mutex> lock(mu_); setErrorLocked(e); }
  /// Logs an error once per kind (the text before any " for "); diagnostics carry the details.
  void setErrorLocked(const std::string& e) {
    std::string kind = e.substr(0, e.find(" for "));
    if (kind != error_kind_) ROS_ERROR_STREAM("skeleton_tracker: " << e);
    error_kind_ = kind;
    error_ = e;
  }

  /// A failed open: ERROR with the reason, which is logged again when it
  /// changes and every 30 s while it lasts; the run loop retries every
  /// reopen_period (not after a fatal error: a backend that cannot work).
  void openFailed(const std::string& why) {
    std::lock_guard<std::mutex> lock(mu_);
    ++open_failures_;
    error_ = why;
    if (!fatal_) {
      error_ += "; retrying every " + fmt(reopen_period_, 1) + " s (attempt " + std::to_string(open_failures_) + ")";
    }
    const double now = localNow();
    if (error_kind_ != why || now - open_logged_ >= 30.0) {
      ROS_ERROR_STREAM("skeleton_tracker: " << error_);
      open_logged_ = now;
    }
    error_kind_ = why;
  }

  void openDevice() {
    auto dev = std::make_unique<openni::Device>();
    const char* uri = device_uri_.empty() ? openni::ANY_DEVICE : device_uri_.c_str();
    if (dev->open(uri) != openni::STATUS_OK) {
      std::string why = oneLine(openni::OpenNI::getExtendedError());
      if (is_file_) why = std::ifstream(device_uri_).good() ? "not a readable .oni recording (corrupt?) " + why : "no such file";
      openFailed("cannot open " + uriLabel() + ": " + why);
      return;
    }
    auto depth = std::make_unique<openni::VideoStream>();
    if (depth->create(*dev, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      openFailed(uriLabel() + " has no depth stream: " + oneLine(openni::OpenNI::getExtendedError()));
      dev->close();
      return;
    }
    int total = 0;
    if (dev->isFile()) {
      openni::PlaybackControl* pb = dev->getPlaybackControl();
      pb->setRepeatEnabled(loop_);
      pb->setSpeed(1.0f);
      total = pb->getNumberOfFrames(*depth);
      if (total <= 0) {
        openFailed("recording " + uriLabel() + " holds no depth frames (corrupt .oni?)");
        depth->destroy();
        dev->close();
        return;
      }
    }
    openni::VideoMode mode = depth->getVideoMode();
    Camera cam;
    cam.width = mode.getResolutionX();
    cam.height = mode.getResolutionY();
    cam.setFov(depth->getHorizontalFieldOfView(), depth->getVerticalFieldOfView());
    if (mode.getPixelFormat() != openni::PIXEL_FORMAT_DEPTH_1_MM || cam.width <= 0 || !(cam.hfov() > 0.1)) {
      openFailed(uriLabel() + ": unsupported depth mode (need 1 mm depth with a field of view)");
      depth->destroy();
      dev->close();
      return;
    }
    std::unique_ptr<NiteBackend> nite;
    if (backend_name_ == "nite") {
      try {
        nite = std::make_unique<NiteBackend>(dev.get());
      } catch (const std::exception& e) {
        fatal_ = true;
        openFailed(e.what());
        depth->destroy();
        dev->close();
        return;
      }
    } else if (depth->start() != openni::STATUS_OK) {
      openFailed("cannot start depth on " + uriLabel() + ": " + oneLine(openni::OpenNI::getExtendedError()));
      depth->destroy();
      dev->close();
      return;
    }
    std::lock_guard<std::mutex> lock(mu_);
    device_ = std::move(dev);
    depth_ = std::move(depth);
    nite_ = std::move(nite);
    MultiParams multi;
    multi.max_users = max_users_;
    tracker_ = std::make_unique<MultiTracker>(cam, TrackerParams(), multi);
    mapper_.reset();
    lost_ = false;
    total_frames_ = total;
    last_index_ = 0;
    last_frame_local_ = 0;
    opened_local_ = localNow();
    resolution_ = std::to_string(cam.width) + "x" + std::to_string(cam.height);
    state_ = "opened";
    open_failures_ = 0;
    error_.clear();
    error_kind_.clear();
    ROS_INFO_STREAM("skeleton_tracker: " << client_id_ << " reads " << uriLabel() << " (" << resolution_
                    << ", backend " << backend_name_ << ")");
  }

  void closeDevice() { std::lock_guard<std::mutex> lock(mu_); closeDeviceLocked(); }
  void closeDeviceLocked() {
    nite_.reset();
    if (depth_) { depth_->stop(); depth_->destroy(); depth_.reset(); }
    if (device_) { device_->close(); device_.reset(); }
    tracker_.reset();
    users_ = MultiEstimate();
  }

  /// NiTE's one user as the multi-user tracker's output (user id 1).
  static MultiEstimate single(const SkeletonEstimate& est) {
    MultiEstimate m;
    m.state = est.state;
    if (!est.tracked) return m;
    m.users.push_back({1, est, Vec3()});
    m.tracked_users = 1;
    m.people_in_view = 1;
    return m;
  }

  void handleFrame() {
    MultiEstimate est;
    double arrival = 0;  // local: the fit uses the earliest arrivals only
    unsigned long long device_us = 0;
    int index = 0;
    if (nite_) {
      try {
        est = single(nite_->read(&device_us, &index));
        arrival = localNow();
      } catch (const std::exception& e) {
        setError(e.what());
        return;
      }
    } else {
      openni::VideoFrameRef f;
      if (depth_->readFrame(&f) != openni::STATUS_OK || !f.isValid()) {
        setError("readFrame failed: " + oneLine(openni::OpenNI::getExtendedError()));
        return;
      }
      arrival = localNow();
      device_us = f.getTimestamp();
      index = f.getFrameIndex();
      est = tracker_->update(static_cast<const uint16_t*>(f.getData()), device_us * 1e-6);
    }
    const double device_s = device_us * 1e-6;
    std::lock_guard<std::mutex> lock(mu_);
    ++frames_;
    if (!error_.empty()) {
      ROS_INFO_STREAM("skeleton_tracker: frames again from " << uriLabel());
      error_.clear();
      error_kind_.clear();
    }
    if (last_index_ > 0 && index > last_index_ + 1) dropped_ += index - last_index_ - 1;
    const unsigned long resets = mapper_.resets();
    mapper_.observe(device_s, arrival);
    if (mapper_.resets() != resets) {
      if (tracker_) tracker_->reset();
      fps_window_.clear();
      ROS_WARN_STREAM("skeleton_tracker: device clock went back (recording looped or sensor reset); "
                      "re-estimating the device clock");
    }
    last_index_ = index;
    last_frame_local_ = arrival;
    fps_window_.push_back(device_s);
    while (fps_window_.size() > 1 && fps_window_.back() - fps_window_.front() > 2.0) fps_window_.pop_front();
    state_ = est.state;
    users_ = est;
    logState(device_s);
    tracked_ += est.tracked_users > 0;
    if (est.tracked_users == 0) return;
    if (!clock_.ready || !mapper_.ready()) { ++withheld_; return; }
    const double global = clock_.model.toGlobal(mapper_.toLocal(device_s));
    // The device clock map moves down after late arrivals: a frame it now
    // maps at or before the last one published is withheld, so the
    // stamps go forward (docs/tracker.md).
    if (global <= last_global_) { ++withheld_back_; return; }
    last_global_ = global;
    for (const UserEstimate& u : est.users) {
      if (u.estimate.tracked) publishSkeleton(u.user_id, u.estimate, global, device_s, index);
    }
  }

  /// Logs a tracking state once it has held for kStateHold s of device time
  /// (a state that flickers for a frame or two is not logged), with what
  /// the first user's frame showed: why a tracker that stops publishing
  /// stopped is in the log, not only on the 1 Hz diagnostics (mu_ held).
  void logState(double device_s) {
    // A device clock that went back (a recording looped) starts the span over.
    if (state_ != pending_state_ || device_s < pending_since_) {
      pending_state_ = state_;
      pending_since_ = device_s;
    }
    if (pending_state_ == logged_state_ || device_s - pending_since_ < kStateHold) return;
    std::string detail;
    if (!users_.users.empty()) {
      const SkeletonEstimate& e = users_.users.front().estimate;
      detail = "; user " + std::to_string(users_.users.front().user_id) + ": " + std::to_string(e.user_cells) +
               " cells, " + std::to_string(e.extremities) + " extremities, " + std::to_string(e.labelled) +
               " taken for a head, hand or foot";
    }
    detail += users_.floor_height < 0 ? "; no floor" : "; sensor " + fmt(users_.floor_height, 2) + " m above the floor";
    ROS_INFO_STREAM("skeleton_tracker: " << client_id_ << ": " << pending_state_ << " for "
                    << fmt(device_s - pending_since_, 2) << " s at frame " << last_index_ << " (was " << logged_state_
                    << "; " << dropped_ << " frames dropped so far)" << detail);
    logged_state_ = pending_state_;
  }

  /// One user's skeleton of frame ``index``, with the frames skipped so far (mu_ held).
  void publishSkeleton(uint32_t user_id, const SkeletonEstimate& est, double global, double device_s, int index) {
    hri_sync::Skeleton msg;
    msg.header.stamp.fromSec(global);
    msg.header.frame_id = frame_id_;
    msg.client_id = client_id_;
    msg.user_id = user_id;
    msg.device_stamp.fromSec(device_s);
    msg.frame_index = index > 0 ? static_cast<uint32_t>(index) : 0;
    msg.frames_skipped = static_cast<uint32_t>(dropped_);
    for (int k = 0; k < NUM_JOINTS; ++k) {
      msg.positions[k].x = est.joints[k].x;
      msg.positions[k].y = est.joints[k].y;
      msg.positions[k].z = est.joints[k].z;
      msg.orientations[k].w = 1.0;  // the depth backend estimates positions only
      msg.confidence[k] = est.confidence[k];
    }
    skeleton_pub_.publish(msg);
    ++published_;
  }

  /// The tracked users' ids, "1 3" (mu_ held).
  std::string userIds() const {
    std::string ids;
    for (const UserEstimate& u : users_.users) {
      if (u.estimate.tracked) ids += (ids.empty() ? "" : " ") + std::to_string(u.user_id);
    }
    return ids;
  }

  /// Each calibrated user's body model, e.g. "1: 1.72 m, girth 1.04; 3: 1.60 m, girth 1.12".
  std::string userBodies() const {
    std::string out;
    for (const UserEstimate& u : users_.users) {
      if (u.estimate.body_height <= 0) continue;
      out += (out.empty() ? "" : "; ") + std::to_string(u.user_id) + ": " + fmt(u.estimate.body_height, 2) +
             " m, girth " + fmt(u.estimate.girth, 2);
    }
    return out;
  }

  void publishDiagnostics(const ros::WallTimerEvent&) {
    diagnostic_msgs::DiagnosticArray arr;
    arr.header.stamp = ros::Time::now();
    diagnostic_msgs::DiagnosticStatus s;
    // "<node name>: sensor" as diagnostic_updater names the Python nodes'
    // statuses (e.g. "lab1/left/tracker: sensor"): unique per system.
    s.name = ros::this_node::getName().substr(1) + ": sensor";
    s.hardware_id = device_uri_.empty() ? "openni:any" : device_uri_;
    {
      std::lock_guard<std::mutex> lock(mu_);
      double fps = fps_window_.size() > 1 ? (fps_window_.size() - 1) / (fps_window_.back() - fps_window_.front()) : 0.0;
      if (depth_ && last_frame_local_ > 0 && localNow() - last_frame_local_ > frame_timeout_) fps = 0.0;
      if (!error_.empty()) {
        s.level = diagnostic_msgs::DiagnosticStatus::ERROR;
        s.message = error_;
      } else if (!clock_.ready) {
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = "not publishing: no valid global clock (" + clock_.reason + ") on " + clock_sub_.getTopic();
      } else if (!depth_) {
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = "opening " + uriLabel();
      } else if (state_ != "tracking") {
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = "not tracking: " + state_;
      } else {
        s.level = diagnostic_msgs::DiagnosticStatus::OK;
        s.message = users_.tracked_users > 1 ? "tracking " + std::to_string(users_.tracked_users) + " users" : "tracking";
      }
      auto kv = [&s](const std::string& k, const std::string& v) {
        diagnostic_msgs::KeyValue p;
        p.key = k;
        p.value = v;
        s.values.push_back(p);
      };
      kv("backend", backend_name_);
      kv("resolution", resolution_);
      kv("frame_rate_hz", fmt(fps, 1));
      kv("frames", std::to_string(frames_));
      kv("frames_tracked", std::to_string(tracked_));
      kv("skeletons_published", std::to_string(published_));
      kv("dropped_frames", std::to_string(dropped_));
      kv("withheld_no_clock", std::to_string(withheld_));
      kv("withheld_stamp_back", std::to_string(withheld_back_));
      kv("failed_opens", std::to_string(open_failures_));
      kv("tracking_state", state_);
      kv("tracked_users", std::to_string(users_.tracked_users));
      kv("tracked_user_ids", userIds());
      kv("user_bodies", userBodies());
      kv("people_in_view", std::to_string(users_.people_in_view));
      kv("lost_users", std::to_string(users_.lost_users));
      kv("max_users", std::to_string(nite_ ? 1 : max_users_));
      kv("user_ids_issued", std::to_string(tracker_ ? tracker_->idsIssued() : 0));
      kv("global_clock", clock_.ready ? "ok" : clock_.reason);
      kv("device_clock_offset_s", fmt(mapper_.offset(), 6));
      kv("device_clock_drift_ppm", fmt(mapper_.drift() * 1e6, 1));
      kv("device_clock_restarts", std::to_string(mapper_.resets()));
      kv("mean_arrival_delay_ms", fmt(mapper_.meanDelay() * 1e3, 2));
    }
    arr.status.push_back(s);
    diag_pub_.publish(arr);
    status_pub_.publish(s);
  }

  ros::NodeHandle nh_, pnh_;
  ros::Publisher skeleton_pub_, diag_pub_, status_pub_;
  ros::Subscriber clock_sub_;
  ros::WallTimer diag_timer_;
  std::string device_uri_, backend_name_, client_id_, frame_id_;
  bool loop_ = false, is_file_ = false;
  double frame_timeout_ = 1.0, reopen_period_ = 3.0;
  int max_users_ = 4;
  std::atomic<bool> lost_{false};
  std::atomic<bool> fatal_{false};
  std::atomic<bool> stop_watch_{false}, master_restarted_{false};
  std::thread watcher_;

  std::mutex mu_;  // guards everything below
  std::unique_ptr<openni::Device> device_;
  std::unique_ptr<openni::VideoStream> depth_;
  std::unique_ptr<NiteBackend> nite_;
  std::unique_ptr<MultiTracker> tracker_;
  DeviceClockMapper mapper_;
  ClockStatus clock_;
  std::string state_ = "starting", error_, error_kind_, resolution_ = "?";
  static constexpr double kStateHold = 0.5;  // s a state holds before it is logged
  std::string pending_state_, logged_state_ = "starting";
  double pending_since_ = 0;
  std::deque<double> fps_window_;
  MultiEstimate users_;  // the last frame's users
  int total_frames_ = 0, last_index_ = 0;
  double last_frame_local_ = 0, opened_local_ = 0, open_logged_ = 0;
  double last_global_ = 0;  // the last published stamp (global s)
  unsigned long open_failures_ = 0;  // since the last successful open
  unsigned long frames_ = 0, tracked_ = 0, published_ = 0, dropped_ = 0, withheld_ = 0;
  unsigned long withheld_back_ = 0;  // frames whose stamp would go back
};

}  // namespace
}  // namespace hri_sync

int main(int argc, char** argv) {
  ros::init(argc, argv, "skeleton_tracker");
  if (openni::OpenNI::initialize() != openni::STATUS_OK) {
    ROS_FATAL_STREAM("skeleton_tracker: OpenNI2 failed to initialise: " << openni::OpenNI::getExtendedError());
    return 1;
  }
  int status = 0;
  {
    hri_sync::TrackerNode node;
    openni::OpenNI::addDeviceDisconnectedListener(&node);
    ros::AsyncSpinner spinner(1);
    spinner.start();
    node.run();
    spinner.stop();
    openni::OpenNI::removeDeviceDisconnectedListener(&node);
    if (node.masterRestarted()) status = hri_sync::kRestartExit;
  }
  openni::OpenNI::shutdown();
  return status;
}
