#include "hri_sync/body.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hri_sync {

const char* const kJointNames[NUM_JOINTS] = {
    "head", "neck", "torso", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_hand", "right_hand", "left_hip", "right_hip", "left_knee", "right_knee",
    "left_foot", "right_foot"};

Track Track::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open track file '" + path + "'");
  std::vector<double> times;
  std::vector<Joints> frames;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    double t;
    Joints j;
    bool ok = static_cast<bool>(ss >> t);
    for (int k = 0; ok && k < NUM_JOINTS; ++k) ok = static_cast<bool>(ss >> j[k].x >> j[k].y >> j[k].z);
    std::string rest;
    if (!ok || (ss >> rest)) {
      throw std::runtime_error(path + ":" + std::to_string(lineno) +
                               ": expected 46 numbers (t and 15 x y z)");
    }
    for (const auto& p : j) {
      if (!p.finite() || !std::isfinite(t)) {
        throw std::runtime_error(path + ":" + std::to_string(lineno) + ": non-finite value");
      }
    }
    if (!times.empty() && t <= times.back()) {
      throw std::runtime_error(path + ":" + std::to_string(lineno) + ": times must increase");
    }
    times.push_back(t);
    frames.push_back(j);
  }
  if (times.size() < 2) throw std::runtime_error(path + ": fewer than 2 frames");
  return fromFrames(std::move(times), std::move(frames));
}

Track Track::fromFrames(std::vector<double> times, std::vector<Joints> frames) {
  Track tr;
  tr.times_ = std::move(times);
  tr.frames_ = std::move(frames);
  return tr;
}

Joints Track::at(double t, bool loop) const {
  if (times_.empty()) return Joints();
  double t0 = times_.front(), dur = times_.back() - t0;
  if (loop && dur > 0) {
    t = t0 + std::fmod(t - t0, dur);
    if (t < t0) t += dur;
  }
  if (t <= t0) return frames_.front();
  if (t >= times_.back()) return frames_.back();
  size_t i = std::upper_bound(times_.begin(), times_.end(), t) - times_.begin();
  double a = (t - times_[i - 1]) / (times_[i] - times_[i - 1]);
  Joints out;
  for (int k = 0; k < NUM_JOINTS; ++k) out[k] = frames_[i - 1][k] * (1 - a) + frames_[i][k] * a;
  return out;
}

}  // namespace hri_sync
