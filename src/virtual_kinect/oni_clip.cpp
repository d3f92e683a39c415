#include "hri_sync/oni_clip.h"

#include <OpenNI.h>

#include <algorithm>
#include <cstdio>

namespace hri_sync {

bool readOniClip(const std::string& path, int max_frames, DepthClip* clip) {
  openni::Device dev;
  openni::VideoStream depth;
  if (dev.open(path.c_str()) != openni::STATUS_OK || !dev.isFile() ||
      depth.create(dev, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    std::fprintf(stderr, "cannot read depth from '%s': %s\n", path.c_str(), openni::OpenNI::getExtendedError());
    return false;
  }
  openni::PlaybackControl* pb = dev.getPlaybackControl();
  int n = pb->getNumberOfFrames(depth);
  if (max_frames > 0) n = std::min(n, max_frames);
  pb->setSpeed(-1);  // manual stepping: every frame once
  pb->setRepeatEnabled(false);
  depth.start();
  clip->hfov = depth.getHorizontalFieldOfView();
  clip->vfov = depth.getVerticalFieldOfView();
  openni::VideoFrameRef f;
  for (int i = 0; i < n; ++i) {
    if (depth.readFrame(&f) != openni::STATUS_OK) break;
    clip->width = f.getWidth();
    clip->height = f.getHeight();
    const auto* px = static_cast<const openni::DepthPixel*>(f.getData());
    clip->frames.emplace_back(px, px + clip->width * clip->height);
    clip->stamps.push_back(f.getTimestamp() * 1e-6);
  }
  return !clip->frames.empty();
}

}  // namespace hri_sync
