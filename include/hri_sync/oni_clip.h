// A short .oni recording read whole into memory, frame by frame (every frame
// once, in order), for the tools that measure a real clip: depth_noise_stats
// and tracker_eval --oni.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hri_sync {

struct DepthClip {
  int width = 0, height = 0;
  double hfov = 0, vfov = 0;                  ///< the depth stream's fields of view (rad)
  std::vector<std::vector<uint16_t>> frames;  ///< depth, mm (0: no reading)
  std::vector<double> stamps;                 ///< device timestamps, s
};

/// Reads up to max_frames (<= 0: all) depth frames of an .oni file. Needs
/// OpenNI initialized; false with a message on stderr when nothing is read.
/// The stock file player can crash while its streams are torn down: callers
/// leave with std::_Exit once done.
bool readOniClip(const std::string& path, int max_frames, DepthClip* clip);

}  // namespace hri_sync
