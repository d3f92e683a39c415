#include "hri_sync/multi_tracker.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hri_sync {

MultiTracker::MultiTracker(const Camera& cam, TrackerParams params, MultiParams multi)
    : cam_(cam), params_(params), multi_(multi) {
  if (multi_.max_users < 1 || multi_.max_users > 4) throw std::invalid_argument("max_users must be 1-4");
  if (params_.grid_step <= 0) params_.grid_step = std::max(1, cam.width / 160);
}

double MultiTracker::acrossFloor(const Vec3& a, const Vec3& b) const {
  const Vec3 up = room_.floor().found ? room_.floor().n : Vec3(0, 1, 0);
  const Vec3 d = a - b;
  return (d - up * d.dot(up)).norm();
}

void MultiTracker::reset() {
  room_.reset();
  steadier_.reset();
  users_.clear();
  next_id_ = 1;
}

std::vector<int> MultiTracker::associate(const std::vector<Blob>& parts, const std::vector<int>& people,
                                         double t) const {
  std::vector<int> taken_by(users_.size(), -1);
  std::vector<uint8_t> used(parts.size(), 0);
  struct Pair {
    double score;
    size_t user;
    int part;
  };
  for (bool lost_pass : {false, true}) {  // users seen last frame first, then lost ones
    std::vector<Pair> pairs;
    for (size_t u = 0; u < users_.size(); ++u) {
      const User& user = users_[u];
      if (user.seen == lost_pass) continue;
      const double gate = user.seen ? multi_.gate
                                    : std::min(multi_.max_gate, multi_.gate + multi_.regain_speed * (t - user.last_seen));
      for (int k : people) {
        if (used[k]) continue;
        const double d = acrossFloor(parts[k].centroid, user.centroid);
        if (d <= gate) pairs.push_back({parts[k].cells.size() / (0.1 + d), u, k});
      }
    }
    std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.score > b.score; });
    for (const Pair& p : pairs) {
      if (taken_by[p.user] >= 0 || used[p.part]) continue;
      bool piece = false;  // a body beside one already taken is a piece of that user (split by an occluder)
      for (int q : taken_by) piece |= q >= 0 && acrossFloor(parts[q].centroid, parts[p.part].centroid) < multi_.same_person;
      if (piece) continue;
      taken_by[p.user] = p.part;
      used[p.part] = 1;
    }
  }
  return taken_by;
}

void MultiTracker::admit(const PointGrid& g, const std::vector<Blob>& parts, const std::vector<int>& people, double t,
                         std::vector<int>* taken_by) {
  std::vector<int> free;
  for (int k : people) {
    if (std::find(taken_by->begin(), taken_by->end(), k) == taken_by->end()) free.push_back(k);
  }
  std::stable_sort(free.begin(), free.end(), [&](int a, int b) {
    return personScore(parts[a], nullptr) > personScore(parts[b], nullptr);
  });
  for (int k : free) {
    int active = 0;
    bool near = false;
    for (int p : *taken_by) {
      if (p < 0) continue;
      ++active;
      near |= acrossFloor(parts[p].centroid, parts[k].centroid) < multi_.same_person;
    }
    // Beside a user, only a body tall enough to be a standing person (not a
    // chair or a table) is someone new, and not a piece of that user.
    if (active > 0 && (near || parts[k].hi < multi_.new_user_top ||
                       static_cast<int>(parts[k].cells.size()) < multi_.new_user_cells)) {
      continue;
    }
    if (active >= multi_.max_users || !notAPerson(g, parts[k], room_.floor()).empty()) continue;
    if (static_cast<int>(users_.size()) >= multi_.max_users) {  // room: forget the longest lost
      size_t oldest = users_.size();
      for (size_t u = 0; u < users_.size(); ++u) {
        if ((*taken_by)[u] < 0 && (oldest == users_.size() || users_[u].last_seen < users_[oldest].last_seen)) oldest = u;
      }
      users_.erase(users_.begin() + oldest);
      taken_by->erase(taken_by->begin() + oldest);
    }
    User user;
    user.id = next_id_++;
    user.tracker = std::make_unique<DepthTracker>(cam_, params_);
    user.centroid = parts[k].centroid;
    user.last_seen = t;
    users_.push_back(std::move(user));
    taken_by->push_back(k);
  }
}

std::vector<std::vector<int>> MultiTracker::fragments(const std::vector<Blob>& parts,
                                                      const std::vector<int>& taken_by) const {
  std::vector<std::vector<int>> out(taken_by.size());
  for (size_t k = 0; k < parts.size(); ++k) {
    if (std::find(taken_by.begin(), taken_by.end(), static_cast<int>(k)) != taken_by.end()) continue;
    int best = -1;
    double best_d = 0;
    for (size_t u = 0; u < taken_by.size(); ++u) {
      if (taken_by[u] < 0 || !isFragmentOf(parts[k], parts[taken_by[u]])) continue;
      const double d = acrossFloor(parts[k].centroid, parts[taken_by[u]].centroid);
      if (best < 0 || d < best_d) { best = static_cast<int>(u); best_d = d; }
    }
    if (best >= 0) out[best].push_back(static_cast<int>(k));
  }
  return out;
}

MultiEstimate MultiTracker::update(const uint16_t* depth_mm, double t) {
  MultiEstimate out;
  PointGrid g = makeGrid(depth_mm, cam_, params_.grid_step);
  if (params_.steady_depth) steadier_.correct(&g);
  room_.update(g, params_.wall_hold);
  users_.erase(std::remove_if(users_.begin(), users_.end(), [&](const User& u) {
                 return !u.seen && (t - u.last_seen > multi_.lost_timeout || t < u.last_seen);
               }), users_.end());
  const std::vector<Blob> parts = blobs(g, room_.floor(), room_.wallCells());
  std::vector<int> people;
  for (size_t k = 0; k < parts.size(); ++k) if (personSized(g, parts[k])) people.push_back(static_cast<int>(k));
  std::vector<int> taken_by = associate(parts, people, t);
  admit(g, parts, people, t, &taken_by);
  const std::vector<std::vector<int>> frags = fragments(parts, taken_by);
  for (size_t u = 0; u < users_.size(); ++u) {
    User& user = users_[u];
    if (taken_by[u] < 0) {
      if (user.seen) user.tracker->lose();
      user.seen = false;
      ++out.lost_users;
      continue;
    }
    const Segmentation seg = partSegmentation(g.width * g.height, parts, taken_by[u], frags[u]);
    user.centroid = seg.centroid;
    user.last_seen = t;
    user.seen = true;
    UserEstimate ue{user.id, user.tracker->follow(g, seg, room_.floor(), t), seg.centroid};
    out.tracked_users += ue.estimate.tracked;
    if (out.state.empty()) out.state = ue.estimate.state;
    out.users.push_back(std::move(ue));
  }
  out.people_in_view = static_cast<int>(out.users.size());
  if (room_.floor().found) out.floor_height = room_.floor().height(Vec3());
  for (int k : people) {  // people left out: no room for them
    bool counted = std::find(taken_by.begin(), taken_by.end(), k) != taken_by.end();
    for (int p : taken_by) counted |= p >= 0 && acrossFloor(parts[p].centroid, parts[k].centroid) < multi_.same_person;
    if (!counted && parts[k].hi >= multi_.new_user_top) ++out.people_in_view;
  }
  if (out.tracked_users > 0) out.state = "tracking";
  if (out.users.empty()) out.state = std::string("searching: ") +
                                     (parts.empty() ? "no points off the floor" : "no person-sized object in view");
  return out;
}

}  // namespace hri_sync
