// depth_noise_stats: the depth noise statistics of a short still sequence, as JSON,
// from a recording or from the scene renderer, so that a real Kinect v1 clip and
// the virtual Kinect's model are measured by the same code.
//
//   depth_noise_stats FILE.oni [--split M] [--frames N] [--first K]
//   depth_noise_stats --track FILE.track --scene 'KEYS' [--frames N] [--res 640x480|320x240]
//                     [--split M]
//   --first K drops the first K frames (a person still moving into place);
//   --raw FILE also writes the frames (uint16 mm, W x H, one after another).
//
// A recording has no labels: pixels whose temporal median depth is nearer than
// --split (1.8 m) are "person", the rest "wall" (the background). A scene's
// pixels are split by the renderer's labels (person, wall) unless --split is
// given. Frame n of a scene is Scene::render(n / 30 s, n + 1), as tracker_eval
// renders it. Figures (docs/tracker.md, "Kinect v1 noise"):
//   temporal std per pixel (mm and disparity units, z = 1 / (c1 d + c0)) over the
//     pixels with a reading in every frame, away from depth edges (> 2 px);
//   the depth step seen in those pixels' readings vs the model's |c1| z^2;
//   missing: share of pixels with no reading in any frame; flicker: a reading in
//     some frames, none in others, the readings on one surface (pixels whose
//     readings span > 0.1 m saw something move: "moved", counted apart); the share of flickering pixels within 2 px of
//     a depth edge; the share of missing pixels in patches of 1-2 pixels;
//   spatial autocorrelation of (frame - pixel's temporal mean), disparity units,
//     on the wall at lags 1..10 px along x and y, and the lag where it falls to 1/e;
//   frame-wide offsets: the std over frames of the wall's mean residual, and the
//     residual's frame-to-frame correlation.
#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "hri_sync/oni_clip.h"
#include "hri_sync/scene.h"

using namespace hri_sync;

namespace {

constexpr double kC1 = -2.85e-3, kC0 = 3.11;  // KinectNoise's defaults
double disparity(double z_m) { return (1.0 / z_m - kC0) / kC1; }

struct Clip {
  int w = 0, h = 0;
  std::vector<std::vector<uint16_t>> frames;
  std::vector<uint8_t> label;  // from a scene, else empty
};

bool readOni(const std::string& path, int max_frames, Clip* clip) {
  if (openni::OpenNI::initialize() != openni::STATUS_OK) {
    std::fprintf(stderr, "depth_noise_stats: OpenNI init failed: %s\n", openni::OpenNI::getExtendedError());
    return false;
  }
  DepthClip real;
  if (!readOniClip(path, max_frames, &real)) return false;
  clip->w = real.width;
  clip->h = real.height;
  clip->frames = std::move(real.frames);
  return true;
}

bool renderScene(const std::string& track_path, const std::string& query, int frames, const std::string& res,
                 Clip* clip) {
  const SceneSpec spec = parseSceneQuery(query);
  if (spec.scene.needsWalk()) throw std::invalid_argument("a still scene: no bystander or crowd");
  Track track = Track::load(track_path);
  Scene scene(track, spec.body, spec.scene, spec.noise, nullptr, spec.seed);
  Camera cam;
  cam.width = res == "320x240" ? 320 : 640;
  cam.height = res == "320x240" ? 240 : 480;
  clip->w = cam.width;
  clip->h = cam.height;
  SceneFrame fr;
  for (int n = 0; n < frames; ++n) {
    scene.render(n / 30.0, n + 1, cam, &fr);
    clip->frames.push_back(fr.depth_mm);
    if (n == 0) clip->label = fr.label;
  }
  return true;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  size_t k = static_cast<size_t>(q * (v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

void printNumber(double v) {
  if (std::isfinite(v)) std::printf("%.4g", v);
  else std::printf("null");
}

struct Options {
  std::string oni, track, query, res = "640x480", raw;
  int frames = 16, first = 0;
  double split = -1;
};

// The command line; exits with 2 and a usage line on a bad one.
Options parseArgs(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) { std::fprintf(stderr, "depth_noise_stats: %s needs a value\n", a.c_str()); std::exit(2); }
      return argv[++i];
    };
    if (a == "--track") o.track = next();
    else if (a == "--scene") o.query = next();
    else if (a == "--frames") o.frames = std::stoi(next());
    else if (a == "--res") o.res = next();
    else if (a == "--split") o.split = std::stod(next());
    else if (a == "--raw") o.raw = next();
    else if (a == "--first") o.first = std::stoi(next());
    else if (!a.empty() && a[0] != '-' && o.oni.empty()) o.oni = a;
    else { std::fprintf(stderr, "depth_noise_stats: unknown argument %s\n", a.c_str()); std::exit(2); }
  }
  if (o.oni.empty() == o.track.empty() || o.frames < 2) {
    std::fprintf(stderr, "usage: depth_noise_stats FILE.oni [--split M] [--frames N]\n"
                         "       depth_noise_stats --track FILE.track --scene KEYS [--frames N] [--res WxH] [--split M]\n");
    std::exit(2);
  }
  return o;
}

bool writeRaw(const Clip& clip, const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "wb");
  for (const auto& fr : clip.frames) if (f) std::fwrite(fr.data(), sizeof(uint16_t), fr.size(), f);
  return f && std::fclose(f) == 0;
}

// Per pixel: readings, temporal median depth (0: never a reading), class, whether it moved.
struct Pixels {
  int W = 0, H = 0, T = 0;
  size_t N = 0;
  std::vector<int> count;
  std::vector<double> med;
  std::vector<uint8_t> cls;    // 0 none, 1 person, 2 wall
  std::vector<uint8_t> moved;  // readings more than 0.1 m apart: a surface came or went
  std::vector<uint8_t> near_edge;
};

Pixels classify(const Clip& clip, bool by_label, double split) {
  Pixels p;
  p.W = clip.w;
  p.H = clip.h;
  p.T = static_cast<int>(clip.frames.size());
  p.N = static_cast<size_t>(p.W) * p.H;
  p.count.assign(p.N, 0);
  p.med.assign(p.N, 0.0);
  p.cls.assign(p.N, 0);
  p.moved.assign(p.N, 0);
  std::vector<double> buf;
  for (size_t i = 0; i < p.N; ++i) {
    buf.clear();
    for (const auto& f : clip.frames) if (f[i]) buf.push_back(f[i] * 1e-3);
    p.count[i] = static_cast<int>(buf.size());
    if (!buf.empty()) {
      p.med[i] = quantile(buf, 0.5);
      p.moved[i] = *std::max_element(buf.begin(), buf.end()) - *std::min_element(buf.begin(), buf.end()) > 0.1;
    }
    if (by_label) p.cls[i] = clip.label[i] == LABEL_PERSON ? 1 : clip.label[i] == LABEL_WALL ? 2 : 0;
    else if (p.med[i] > 0) p.cls[i] = p.med[i] < split ? 1 : 2;
  }
  return p;
}

// Depth edges of the median image: a 4-neighbour > 0.1 m away, or a reading beside a
// pixel that never reads; then everything within 2 px of one.
void markEdges(Pixels* p) {
  const int W = p->W, H = p->H;
  const auto& med = p->med;
  std::vector<uint8_t> edge(p->N, 0);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = static_cast<size_t>(v) * W + u;
      const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        int uu = u + du[k], vv = v + dv[k];
        if (uu < 0 || vv < 0 || uu >= W || vv >= H) continue;
        const size_t j = static_cast<size_t>(vv) * W + uu;
        if ((med[i] > 0) != (med[j] > 0) || (med[i] > 0 && std::fabs(med[i] - med[j]) > 0.1)) edge[i] = 1;
      }
    }
  }
  p->near_edge.assign(p->N, 0);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      if (!edge[static_cast<size_t>(v) * W + u]) continue;
      for (int vv = std::max(0, v - 2); vv <= std::min(H - 1, v + 2); ++vv)
        for (int uu = std::max(0, u - 2); uu <= std::min(W - 1, u + 2); ++uu)
          p->near_edge[static_cast<size_t>(vv) * W + uu] = 1;
    }
  }
}

// Temporal std and the depth step seen, per class, on steady interior pixels.
struct Steady {
  std::vector<double> std_mm[3], std_disp[3], step_ratio[3], zmed[3];
  std::vector<uint8_t> steady;
  std::vector<double> mean_d;
};

Steady steadyStats(const Clip& clip, const Pixels& p) {
  Steady s;
  s.steady.assign(p.N, 0);
  s.mean_d.assign(p.N, 0.0);
  const int T = p.T;
  for (size_t i = 0; i < p.N; ++i) {
    if (p.count[i] != T || p.near_edge[i] || p.cls[i] == 0 || p.moved[i]) continue;
    s.steady[i] = 1;
    double sz = 0, szz = 0, sd = 0, sdd = 0;
    std::vector<int> vals;
    for (const auto& f : clip.frames) {
      double z = f[i] * 1e-3, d = disparity(z);
      sz += z; szz += z * z; sd += d; sdd += d * d;
      vals.push_back(f[i]);
    }
    s.mean_d[i] = sd / T;
    const int c = p.cls[i];
    s.std_mm[c].push_back(1e3 * std::sqrt(std::max(0.0, (szz - sz * sz / T) / (T - 1))));
    s.std_disp[c].push_back(std::sqrt(std::max(0.0, (sdd - sd * sd / T) / (T - 1))));
    s.zmed[c].push_back(p.med[i]);
    std::sort(vals.begin(), vals.end());
    int step = 0;
    for (size_t k = 1; k < vals.size(); ++k) {
      int d = vals[k] - vals[k - 1];
      if (d > 0 && (step == 0 || d < step)) step = d;
    }
    if (step > 0) s.step_ratio[c].push_back(step * 1e-3 / (std::fabs(kC1) * p.med[i] * p.med[i]));
  }
  return s;
}

// Missing and flickering pixels, and missing readings in patches.
struct Gaps {
  size_t missing = 0, flicker = 0, flicker_edge = 0, moved = 0, flicker_cls[3] = {0, 0, 0}, n_cls[3] = {0, 0, 0};
  size_t zero_px = 0, zero_small = 0;
};

// Per frame, the 4-connected components of pixels without a reading: adds their
// pixels to zero_px, and those in components of 1-2 pixels to zero_small.
void countPatches(const std::vector<uint16_t>& f, int W, int H, Gaps* g) {
  const size_t N = f.size();
  std::vector<uint8_t> seen(N, 0);
  std::vector<size_t> stack;
  for (size_t s = 0; s < N; ++s) {
    if (f[s] || seen[s]) continue;
    size_t members = 0;
    stack.assign(1, s);
    seen[s] = 1;
    while (!stack.empty()) {
      size_t q = stack.back();
      stack.pop_back();
      ++members;
      int u = static_cast<int>(q % W), v = static_cast<int>(q / W);
      const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        int uu = u + du[k], vv = v + dv[k];
        if (uu < 0 || vv < 0 || uu >= W || vv >= H) continue;
        size_t r = static_cast<size_t>(vv) * W + uu;
        if (!f[r] && !seen[r]) { seen[r] = 1; stack.push_back(r); }
      }
    }
    g->zero_px += members;
    if (members <= 2) g->zero_small += members;
  }
}

Gaps gapStats(const Clip& clip, const Pixels& p) {
  Gaps g;
  for (size_t i = 0; i < p.N; ++i) {
    ++g.n_cls[p.cls[i]];
    if (p.moved[i]) ++g.moved;
    if (p.count[i] == 0) ++g.missing;
    else if (p.count[i] < p.T && !p.moved[i]) {
      ++g.flicker;
      ++g.flicker_cls[p.cls[i]];
      g.flicker_edge += p.near_edge[i];
    }
  }
  for (const auto& f : clip.frames) countPatches(f, p.W, p.H, &g);
  return g;
}

// Residuals (disparity units) on the steady wall: spatial autocorrelation at lags
// 0..10 along x and y, frame offsets, frame-to-frame correlation.
struct Residuals {
  double corr[2][11], corr_len[2];
  double offset_std = 0, frame_to_frame = std::nan("");
};

Residuals wallResiduals(const Clip& clip, const Pixels& p, const Steady& st) {
  const int W = p.W, H = p.H, T = p.T;
  const size_t N = p.N;
  auto wall = [&](size_t i) { return st.steady[i] && p.cls[i] == 2; };
  double ac[2][11] = {{0}}, ac_n[2][11] = {{0}};
  std::vector<double> frame_mean;
  double r0 = 0, r1 = 0;
  std::vector<float> r_prev(N, 0.f), r(N, 0.f);
  for (int t = 0; t < T; ++t) {
    const auto& f = clip.frames[t];
    std::fill(r.begin(), r.end(), 0.f);
    double s = 0;
    size_t n = 0;
    for (size_t i = 0; i < N; ++i) {
      if (!wall(i)) continue;
      r[i] = static_cast<float>(disparity(f[i] * 1e-3) - st.mean_d[i]);
      s += r[i];
      ++n;
      r0 += r[i] * r[i];
      if (t > 0) r1 += r[i] * r_prev[i];
    }
    frame_mean.push_back(n ? s / n : 0.0);
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const size_t i = static_cast<size_t>(v) * W + u;
        if (!wall(i)) continue;
        for (int k = 0; k <= 10; ++k) {
          const size_t down = i + static_cast<size_t>(k) * W;
          if (u + k < W && wall(i + k)) { ac[0][k] += r[i] * r[i + k]; ac_n[0][k] += 1; }
          if (v + k < H && wall(down)) { ac[1][k] += r[i] * r[down]; ac_n[1][k] += 1; }
        }
      }
    }
    r_prev.swap(r);
  }
  Residuals out;
  for (int a = 0; a < 2; ++a) {
    out.corr_len[a] = std::nan("");
    for (int k = 0; k <= 10; ++k)
      out.corr[a][k] = ac_n[a][k] > 0 && ac[a][0] > 0 ? (ac[a][k] / ac_n[a][k]) / (ac[a][0] / ac_n[a][0]) : std::nan("");
    for (int k = 1; k <= 10; ++k) {
      if (out.corr[a][k] < std::exp(-1.0)) {
        out.corr_len[a] = (k - 1) + (out.corr[a][k - 1] - std::exp(-1.0)) / (out.corr[a][k - 1] - out.corr[a][k]);
        break;
      }
    }
  }
  double fm = 0, fv = 0;
  for (double m : frame_mean) fm += m / T;
  for (double m : frame_mean) fv += (m - fm) * (m - fm) / (T - 1);
  out.offset_std = std::sqrt(fv);
  if (r0 > 0) out.frame_to_frame = r1 / r0 * T / (T - 1);
  return out;
}

// {"median": ..., "p95": ...} of the values.
void printSpread(const std::vector<double>& v) {
  std::printf("{\"median\": ");
  printNumber(quantile(v, 0.5));
  std::printf(", \"p95\": ");
  printNumber(quantile(v, 0.95));
  std::printf("}");
}

void printList(const double* v) {
  std::printf("[");
  for (int k = 1; k <= 10; ++k) { printNumber(v[k]); std::printf(k < 10 ? ", " : "]"); }
}

void printReport(const Options& o, bool by_label, const Pixels& p, const Steady& s, const Gaps& g,
                 const Residuals& r) {
  const double N = static_cast<double>(p.N);
  std::printf("{\"source\": \"%s\", \"frames\": %d, \"width\": %d, \"height\": %d, \"classes\": \"%s\",\n",
              o.oni.empty() ? ("scene " + o.query).c_str() : o.oni.c_str(), p.T, p.W, p.H,
              by_label ? "renderer labels" : ("median depth split at " + std::to_string(o.split) + " m").c_str());
  const char* names[3] = {"", "person", "wall"};
  for (int c = 1; c <= 2; ++c) {
    std::printf("  \"%s\": {\"pixels\": %zu, \"steady_pixels\": %zu, \"median_depth_m\": ", names[c], g.n_cls[c],
                s.std_mm[c].size());
    printNumber(quantile(s.zmed[c], 0.5));
    std::printf(", \"temporal_std_mm\": ");
    printSpread(s.std_mm[c]);
    std::printf(", \"temporal_std_disp\": ");
    printSpread(s.std_disp[c]);
    std::printf(", \"depth_step_vs_model\": ");
    printNumber(quantile(s.step_ratio[c], 0.5));
    std::printf(", \"flicker_share\": ");
    printNumber(g.n_cls[c] ? static_cast<double>(g.flicker_cls[c]) / g.n_cls[c] : std::nan(""));
    std::printf("},\n");
  }
  std::printf("  \"missing_share\": %.4f, \"flicker_share\": %.4f, \"flicker_near_edge_share\": ", g.missing / N,
              g.flicker / N);
  printNumber(g.flicker ? double(g.flicker_edge) / g.flicker : std::nan(""));
  std::printf(", \"missing_in_1_2_px_patches_share\": ");
  printNumber(g.zero_px ? double(g.zero_small) / g.zero_px : std::nan(""));
  std::printf(", \"moved_share\": %.4f", g.moved / N);
  std::printf(",\n  \"wall_autocorr_x\": ");
  printList(r.corr[0]);
  std::printf(", \"wall_autocorr_y\": ");
  printList(r.corr[1]);
  std::printf(",\n  \"wall_corr_length_px\": {\"x\": ");
  printNumber(r.corr_len[0]);
  std::printf(", \"y\": ");
  printNumber(r.corr_len[1]);
  std::printf("}, \"wall_frame_offset_std_disp\": ");
  printNumber(r.offset_std);
  std::printf(", \"wall_frame_to_frame_corr\": ");
  printNumber(r.frame_to_frame);
  std::printf("}\n");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Options o = parseArgs(argc, argv);
  Clip clip;
  try {
    if (!o.oni.empty() ? !readOni(o.oni, o.frames, &clip) : !renderScene(o.track, o.query, o.frames, o.res, &clip))
      return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depth_noise_stats: %s\n", e.what());
    return 2;
  }
  if (!o.raw.empty() && !writeRaw(clip, o.raw)) {  // the frames as read, uint16 mm, row by row
    std::fprintf(stderr, "depth_noise_stats: cannot write %s\n", o.raw.c_str());
    return 1;
  }
  if (o.first > 0) {
    if (o.first + 2 > static_cast<int>(clip.frames.size())) {
      std::fprintf(stderr, "depth_noise_stats: --first leaves < 2 frames\n");
      return 2;
    }
    clip.frames.erase(clip.frames.begin(), clip.frames.begin() + o.first);
  }
  const bool by_label = !clip.label.empty() && o.split < 0;
  if (o.split < 0) o.split = 1.8;
  Pixels p = classify(clip, by_label, o.split);
  markEdges(&p);
  const Steady s = steadyStats(clip, p);
  printReport(o, by_label, p, s, gapStats(clip, p), wallResiduals(clip, p, s));
  // As oni_info: the stock file player can crash while its streams are torn down.
  std::_Exit(0);
}
