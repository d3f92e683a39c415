// record_oni URI OUT.oni SECONDS: records the depth stream of an OpenNI2 device
// (a virtual:// Kinect or real hardware) into an .oni file with the stock Recorder.
#include <OpenNI.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s URI OUT.oni SECONDS\n", argv[0]);
    return 2;
  }
  const double seconds = std::atof(argv[3]);
  if (!(seconds > 0)) {
    std::fprintf(stderr, "record_oni: SECONDS must be > 0, got '%s'\n", argv[3]);
    return 2;
  }
  if (openni::OpenNI::initialize() != openni::STATUS_OK) {
    std::fprintf(stderr, "record_oni: OpenNI init failed: %s\n", openni::OpenNI::getExtendedError());
    return 1;
  }
  int rc = 0;
  {
    openni::Device dev;
    openni::VideoStream depth;
    openni::Recorder rec;
    if (dev.open(argv[1]) != openni::STATUS_OK) {
      std::fprintf(stderr, "record_oni: cannot open device '%s': %s\n", argv[1], openni::OpenNI::getExtendedError());
      rc = 1;
    } else if (depth.create(dev, openni::SENSOR_DEPTH) != openni::STATUS_OK ||
               rec.create(argv[2]) != openni::STATUS_OK || rec.attach(depth) != openni::STATUS_OK ||
               rec.start() != openni::STATUS_OK || depth.start() != openni::STATUS_OK) {
      std::fprintf(stderr, "record_oni: cannot record to '%s': %s\n", argv[2], openni::OpenNI::getExtendedError());
      rc = 1;
    } else {
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
      depth.stop();
      rec.stop();
      std::printf("recorded %.1f s of depth to %s\n", seconds, argv[2]);
    }
    rec.destroy();
    depth.destroy();
    dev.close();
  }
  openni::OpenNI::shutdown();
  return rc;
}
