// NiTE2 skeleton tracking, loaded at run time (libNiTE2.so is proprietary and
// not packaged): the node's `nite` backend.
#pragma once

#include <memory>
#include <string>

#include "hri_sync/depth_tracker.h"

namespace openni { class Device; }

namespace hri_sync {

class NiteBackend {
 public:
  /// Loads libNiTE2.so (or `library`) and starts a user tracker on the device.
  /// Throws std::runtime_error with a clear message when NiTE is absent or fails.
  NiteBackend(openni::Device* device, const std::string& library = "libNiTE2.so");
  ~NiteBackend();
  NiteBackend(const NiteBackend&) = delete;
  NiteBackend& operator=(const NiteBackend&) = delete;

  /// Reads the next tracker frame; device_us gets its depth frame's timestamp.
  /// Returns the first tracked user's skeleton (metres, sensor frame).
  SkeletonEstimate read(unsigned long long* device_us, int* frame_index);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hri_sync
