// Noticing that the ROS master restarted, for the C++ nodes: the same rule as
// hri_sync.ros.master_watch (Python). roscpp registers a node once; a restarted
// master knows none of its topics, so nothing can find the node again. The node
// asks the master whether it still knows it at its URI; once seen registered, a
// master that answers and does not know it has restarted, and the node ends with
// kRestartExit so that roslaunch's respawn starts it again, registered.
#ifndef HRI_SYNC_MASTER_WATCH_H
#define HRI_SYNC_MASTER_WATCH_H

#include <functional>
#include <string>

namespace hri_sync {

/// EX_TEMPFAIL: try again (roslaunch respawns the node).
constexpr int kRestartExit = 75;

class MasterWatch {
 public:
  enum class State { Waiting, Ok, Unreachable, Restarted };
  /// What the master says of a node: whether it answered, and the URI it has
  /// for the node (empty: it does not know the node).
  struct Answer {
    bool answered = false;
    std::string uri;
  };
  using Lookup = std::function<Answer(const std::string& name)>;

  MasterWatch(std::string name, std::string uri, Lookup lookup)
      : name_(std::move(name)), uri_(std::move(uri)), lookup_(std::move(lookup)) {}

  /// Ask the master once.
  State check() {
    if (state_ == State::Restarted) return state_;
    Answer a = lookup_(name_);
    if (!a.answered) {
      state_ = State::Unreachable;  // only waited for
    } else if (a.uri == uri_) {
      seen_ = true;
      state_ = State::Ok;
    } else if (!seen_) {
      state_ = State::Waiting;
    } else {
      state_ = State::Restarted;
      reason_ = "the ROS master no longer knows " + name_ + " at " + uri_ +
                (a.uri.empty() ? "" : " (it has " + a.uri + " under that name)") +
                ": it restarted, and this node's topics are gone";
    }
    return state_;
  }

  const std::string& reason() const { return reason_; }

 private:
  std::string name_, uri_;
  Lookup lookup_;
  bool seen_ = false;
  State state_ = State::Waiting;
  std::string reason_;
};

}  // namespace hri_sync

#endif  // HRI_SYNC_MASTER_WATCH_H
