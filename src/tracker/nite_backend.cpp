#include "hri_sync/nite_backend.h"

#include <dlfcn.h>

#include <OniCTypes.h>

#include <stdexcept>

namespace hri_sync {

namespace {

// The NiTE 2.2 C API (NiteCAPI.h / NiteCTypes.h), declared here because its
// headers are not installable: only what the backend reads.
using NiteUserTrackerHandle = void*;
using NiteUserId = short;
struct NitePoint3f { float x, y, z; };
struct NiteQuaternion { float x, y, z, w; };
struct NiteSkeletonJoint {
  int jointType;
  NitePoint3f position;
  float positionConfidence;
  NiteQuaternion orientation;
  float orientationConfidence;
};
struct NiteBoundingBox { NitePoint3f min, max; };
struct NitePoseData { int type; int state; };
struct NiteSkeleton { NiteSkeletonJoint joints[15]; int state; };
struct NiteUserData {
  NiteUserId id;
  NiteBoundingBox boundingBox;
  NitePoint3f centerOfMass;
  int state;
  NiteSkeleton skeleton;
  NitePoseData poses[2];
};
struct NiteUserMap { NiteUserId* pixels; int width, height, stride; };
struct NitePlane { NitePoint3f point, normal; };
struct NiteUserTrackerFrame {
  int userCount;
  NiteUserData* pUser;
  NiteUserMap userMap;
  OniFrame* pDepthFrame;
  unsigned long long timestamp;
  int frameIndex;
  float floorConfidence;
  NitePlane floor;
};
constexpr int kNiteOk = 0;
constexpr int kUserNew = 2;
constexpr int kSkeletonNone = 0;
constexpr int kSkeletonTracked = 2;

// NiTE's joint order equals hri_sync's (HEAD, NECK, LEFT/RIGHT_SHOULDER, ...,
// TORSO at 8): map NiTE index -> ours.
constexpr Joint kFromNite[15] = {HEAD, NECK, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_HAND, R_HAND,
                                 TORSO, L_HIP, R_HIP, L_KNEE, R_KNEE, L_FOOT, R_FOOT};

template <typename F>
F symbol(void* lib, const char* name) {
  void* p = dlsym(lib, name);
  if (p == nullptr) throw std::runtime_error(std::string("NiTE2 library lacks ") + name);
  return reinterpret_cast<F>(p);
}

}  // namespace

struct NiteBackend::Impl {
  void* lib = nullptr;
  NiteUserTrackerHandle tracker = nullptr;
  int (*shutdown)() = nullptr;
  int (*shutdownTracker)(NiteUserTrackerHandle) = nullptr;
  int (*startSkeleton)(NiteUserTrackerHandle, NiteUserId) = nullptr;
  int (*readFrame)(NiteUserTrackerHandle, NiteUserTrackerFrame**) = nullptr;
  int (*releaseFrame)(NiteUserTrackerHandle, NiteUserTrackerFrame*) = nullptr;
  ~Impl() {
    if (tracker && shutdownTracker) shutdownTracker(tracker);
    if (shutdown) shutdown();
    if (lib) dlclose(lib);
  }
};

NiteBackend::NiteBackend(openni::Device* device, const std::string& library) : impl_(new Impl) {
  impl_->lib = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (impl_->lib == nullptr) {
    throw std::runtime_error("backend 'nite' needs NiTE2, which is not installed (" + std::string(dlerror()) +
                             "); install NiTE 2.2 and put libNiTE2.so on LD_LIBRARY_PATH, or use backend:=depth");
  }
  auto init = symbol<int (*)()>(impl_->lib, "niteInitialize");
  auto init_tracker = symbol<int (*)(void*, NiteUserTrackerHandle*)>(impl_->lib, "niteInitializeUserTrackerByDevice");
  impl_->shutdownTracker = symbol<int (*)(NiteUserTrackerHandle)>(impl_->lib, "niteShutdownUserTracker");
  impl_->startSkeleton = symbol<int (*)(NiteUserTrackerHandle, NiteUserId)>(impl_->lib, "niteStartSkeletonTracking");
  impl_->readFrame = symbol<int (*)(NiteUserTrackerHandle, NiteUserTrackerFrame**)>(impl_->lib, "niteReadUserTrackerFrame");
  impl_->releaseFrame = symbol<int (*)(NiteUserTrackerHandle, NiteUserTrackerFrame*)>(impl_->lib, "niteUserTrackerFrameRelease");
  if (init() != kNiteOk) throw std::runtime_error("niteInitialize failed (NiTE2 data folder missing?)");
  impl_->shutdown = symbol<int (*)()>(impl_->lib, "niteShutdown");
  if (init_tracker(device, &impl_->tracker) != kNiteOk) {
    impl_->tracker = nullptr;
    throw std::runtime_error("NiTE2 could not start a user tracker on the device");
  }
}

NiteBackend::~NiteBackend() = default;

SkeletonEstimate NiteBackend::read(unsigned long long* device_us, int* frame_index) {
  SkeletonEstimate out;
  out.state = "searching: no user";
  NiteUserTrackerFrame* f = nullptr;
  if (impl_->readFrame(impl_->tracker, &f) != kNiteOk || f == nullptr) {
    throw std::runtime_error("niteReadUserTrackerFrame failed");
  }
  *device_us = f->pDepthFrame ? f->pDepthFrame->timestamp : f->timestamp;
  *frame_index = f->pDepthFrame ? f->pDepthFrame->frameIndex : f->frameIndex;
  for (int u = 0; u < f->userCount; ++u) {
    const NiteUserData& user = f->pUser[u];
    if ((user.state & kUserNew) && user.skeleton.state == kSkeletonNone) impl_->startSkeleton(impl_->tracker, user.id);
    if (user.skeleton.state != kSkeletonTracked) {
      out.state = "calibrating";
      continue;
    }
    for (int k = 0; k < 15; ++k) {
      const NiteSkeletonJoint& nj = user.skeleton.joints[k];
      out.joints[kFromNite[k]] = Vec3(nj.position.x * 1e-3, nj.position.y * 1e-3, nj.position.z * 1e-3);
      out.confidence[kFromNite[k]] = nj.positionConfidence;
    }
    out.tracked = true;
    out.state = "tracking";
    break;
  }
  impl_->releaseFrame(impl_->tracker, f);
  return out;
}

}  // namespace hri_sync
