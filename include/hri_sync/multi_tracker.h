// Several users at once: the room (floor, walls) is found once per frame, every
// person-sized body is a candidate, and each tracked user keeps its own
// DepthTracker (calibration, pose fit, smoothing) under a stable user id.
// docs/tracker.md ("Several users") documents the association rule.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hri_sync/depth_tracker.h"

namespace hri_sync {

struct MultiParams {
  int max_users = 4;          ///< users tracked at once (1-4)
  double gate = 0.8;          ///< m a user's centroid may move along the floor from one frame to the next
  double regain_speed = 1.0;  ///< m/s a lost user's gate grows by while it is lost
  double max_gate = 2.0;      ///< m, the largest gate of a lost user
  double lost_timeout = 3.0;  ///< s a lost user's id is kept for its return
  double new_user_top = 1.0;  ///< m: a new user beside a tracked one reaches this high
  int new_user_cells = 150;   ///< grid cells a new user beside a tracked one covers at least
  double same_person = 0.45;  ///< m across the floor: closer to a user is a piece of them
};

/// One user in one frame.
struct UserEstimate {
  uint32_t user_id = 0;
  SkeletonEstimate estimate;
  Vec3 centroid;               ///< the user's centroid this frame (sensor frame)
};

struct MultiEstimate {
  std::vector<UserEstimate> users;  ///< the users seen this frame, by id
  int tracked_users = 0;       ///< users whose skeleton is tracked this frame
  int people_in_view = 0;      ///< person-sized bodies in view (tracked or not)
  int lost_users = 0;          ///< users lost and waiting (lost_timeout) for their return
  std::string state;           ///< "tracking" when a user is tracked, else the first user's or the search's
  double floor_height = -1;    ///< the sensor's height above the floor it found (m); -1: no floor
};

class MultiTracker {
 public:
  explicit MultiTracker(const Camera& cam, TrackerParams params = TrackerParams(),
                        MultiParams multi = MultiParams());
  /// One depth frame (millimetres) taken at time t (s, device clock).
  MultiEstimate update(const uint16_t* depth_mm, double t);
  /// Forgets every user; ids start at 1 again.
  void reset();
  const MultiParams& params() const { return multi_; }
  /// Ids handed out since the last reset.
  uint32_t idsIssued() const { return next_id_ - 1; }

 private:
  struct User {
    uint32_t id = 0;
    std::unique_ptr<DepthTracker> tracker;
    Vec3 centroid;
    double last_seen = 0;
    bool seen = false;         ///< seen in the last frame
  };
  /// The candidate each user takes this frame (-1: none), users seen last
  /// frame first, then lost ones; greedy by personScore within their gate.
  std::vector<int> associate(const std::vector<Blob>& parts, const std::vector<int>& people, double t) const;
  /// New users for the people nobody took (ids counting up), while there is
  /// room, each passing notAPerson's tests.
  void admit(const PointGrid& g, const std::vector<Blob>& parts, const std::vector<int>& people, double t,
             std::vector<int>* taken_by);
  /// The distance from a to b along the floor (heights left out: the visible
  /// part of a half-hidden person moves up or down, the person does not).
  double acrossFloor(const Vec3& a, const Vec3& b) const;
  /// Per user, the small parts that join it (isFragmentOf; the nearest user's).
  std::vector<std::vector<int>> fragments(const std::vector<Blob>& parts, const std::vector<int>& taken_by) const;

  Camera cam_;
  TrackerParams params_;
  MultiParams multi_;
  Room room_;
  DepthSteadier steadier_;
  std::vector<User> users_;
  uint32_t next_id_ = 1;
};

}  // namespace hri_sync
