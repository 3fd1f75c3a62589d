// Detection time of TagDetector against plain libapriltag on the same real
// photographs in the same run (issue 24: goal <= 1.0x). Plain main, no
// Google Benchmark loop: the pipelines are interleaved (the order rotated
// every repetition) so that load from other work falls on all alike, and
// the per-call times give a median and a p99.
//
//   build/ar/ar_detect_bench [--reps N] [--pipe all|anchor|ours|linear] [--dec 1|2|both]
//                            [--image TEXT]   (only images whose name contains TEXT)
//
// Images: the Swarmathon photos (tests/data/apriltag_photos, 47 tag36h11,
// sRGB JPEGs) and ViSP's photograph (visp-images-data, 12 tag36h11), each
// skipped when absent. Pipelines: "anchor" = apriltag_detector_create()
// defaults with the family added directly (threads 1); "ours" = TagDetector
// with the tracker's default detector options and the sRGB response (the
// refit in linear light); "linear" = TagDetector with the linear response
// (libapriltag behind the wrapper). One pipeline alone (--pipe anchor) is
// for instruction counts: valgrind --tool=callgrind
// --toggle-collect='*detect_all*' build/ar/ar_detect_bench --pipe anchor --reps 1.
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "dentar/ar/tag_detector.h"
#include "dentar/ar/tracker.h"

namespace fs = std::filesystem;
using namespace dentar::ar;

namespace {

struct Image {
  std::string name;
  cv::Mat gray;
};

std::vector<Image> load_images() {
  std::vector<Image> out;
  const fs::path swarm = fs::path(DENTAR_SOURCE_DIR) / "tests/data/apriltag_photos";
  for (const char* stem :
       {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c", "34139872896_defdb2f8d9_c"}) {
    cv::Mat g = cv::imread((swarm / (std::string(stem) + ".jpg")).string(), cv::IMREAD_GRAYSCALE);
    if (!g.empty()) out.push_back({std::string("swarmathon ") + stem, g});
  }
  const fs::path visp = "/usr/share/visp-images-data/ViSP-images/AprilTag/AprilTag.pgm";
  cv::Mat g = cv::imread(visp.string(), cv::IMREAD_GRAYSCALE);
  if (!g.empty()) out.push_back({"visp photo AprilTag.pgm", g});
  return out;
}

class Anchor {
 public:
  explicit Anchor(float decimate) {
    tf_ = tag36h11_create();
    td_ = apriltag_detector_create();
    apriltag_detector_add_family(td_, tf_);
    td_->quad_decimate = decimate;
  }
  ~Anchor() {
    apriltag_detector_destroy(td_);
    tag36h11_destroy(tf_);
  }
  Anchor(const Anchor&) = delete;
  Anchor& operator=(const Anchor&) = delete;
  int detect_all(const cv::Mat& gray) {
    image_u8_t im = {gray.cols, gray.rows, static_cast<int32_t>(gray.step),
                     const_cast<uint8_t*>(gray.ptr<uint8_t>(0))};
    zarray_t* d = apriltag_detector_detect(td_, &im);
    const int n = zarray_size(d);
    apriltag_detections_destroy(d);
    return n;
  }

 private:
  apriltag_family_t* tf_ = nullptr;
  apriltag_detector_t* td_ = nullptr;
};

// Not inlined: the name is what callgrind's --toggle-collect matches.
[[gnu::noinline]] int detect_all(TagDetector& d, const cv::Mat& gray) {
  auto r = d.detect(gray);
  if (!r.ok()) {
    std::fprintf(stderr, "detect: %s\n", r.error().c_str());
    std::exit(1);
  }
  return static_cast<int>(r->size());
}
[[gnu::noinline]] int detect_all(Anchor& a, const cv::Mat& gray) { return a.detect_all(gray); }

struct Pipe {
  std::string name;
  bool anchor;
  std::function<int(const cv::Mat&)> run;
  std::vector<std::vector<double>> ms;   // per image, wall clock
  std::vector<std::vector<double>> cpu;  // per image, this thread's CPU time
  std::vector<int> found;               // per image
};

// CPU time of the calling thread (the detectors run single-threaded): less
// disturbed than wall time by other processes on a loaded machine.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)];
}

int usage(const char* msg) {
  std::fprintf(stderr, "ar_detect_bench: %s\nusage: ar_detect_bench [--reps N (1..10000)] "
               "[--pipe all|anchor|ours|linear] [--dec 1|2|both] [--image TEXT]\n", msg);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 30;
  std::string pipe_sel = "all", dec_sel = "both", image_sel;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage(("missing value after " + a).c_str());
    const std::string v = argv[++i];
    if (a == "--reps") {
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (*end != '\0' || n < 1 || n > 10000) return usage(("--reps " + v + " is not 1..10000").c_str());
      reps = static_cast<int>(n);
    } else if (a == "--pipe") {
      if (v != "all" && v != "anchor" && v != "ours" && v != "linear")
        return usage(("--pipe " + v + " is not all, anchor, ours or linear").c_str());
      pipe_sel = v;
    } else if (a == "--dec") {
      if (v != "1" && v != "2" && v != "both") return usage(("--dec " + v + " is not 1, 2 or both").c_str());
      dec_sel = v;
    } else if (a == "--image") {
      image_sel = v;
    } else {
      return usage(("unknown argument " + a).c_str());
    }
  }
  cv::setNumThreads(1);
  std::vector<Image> images = load_images();
  if (images.empty()) {
    std::fprintf(stderr, "ar_detect_bench: no image found (tests/data/apriltag_photos, visp-images-data)\n");
    return 1;
  }
  std::erase_if(images, [&](const Image& im) { return im.name.find(image_sel) == std::string::npos; });
  if (images.empty()) return usage(("--image " + image_sel + " matches no image").c_str());
  std::printf("| image | decimation | pipeline | tags found | time ms median / p99 | median ÷ anchor "
              "| thread CPU ms median / p99 | CPU median ÷ anchor |\n|---|---|---|---|---|---|---|---|\n");
  for (int dec : {1, 2}) {
    if (dec_sel != "both" && std::to_string(dec) != dec_sel) continue;
    std::vector<Pipe> pipes;
    std::vector<std::shared_ptr<void>> keep;
    if (pipe_sel == "all" || pipe_sel == "anchor") {
      auto a = std::make_shared<Anchor>(static_cast<float>(dec));
      keep.push_back(a);
      pipes.push_back({"anchor (libapriltag)", true, [a](const cv::Mat& g) { return detect_all(*a, g); }, {}, {}, {}});
    }
    for (auto [name, resp] : {std::pair{"ours (sRGB refit)", CameraResponse::kSrgb},
                              std::pair{"ours, linear response", CameraResponse::kLinear}}) {
      const bool want = pipe_sel == "all" || (pipe_sel == "ours" && resp == CameraResponse::kSrgb) ||
                        (pipe_sel == "linear" && resp == CameraResponse::kLinear);
      if (!want) continue;
      TagDetectorOptions o = TrackerOptions{}.detector;
      o.families = {TagFamilyId::kTag36h11};
      o.decimation = dec;
      o.threads = 1;
      o.response = resp;
      auto d = TagDetector::create(o);
      if (!d.ok()) {
        std::fprintf(stderr, "TagDetector: %s\n", d.error().c_str());
        return 1;
      }
      auto det = std::make_shared<TagDetector>(std::move(d).value());
      keep.push_back(det);
      pipes.push_back({name, false, [det](const cv::Mat& g) { return detect_all(*det, g); }, {}, {}, {}});
    }
    for (Pipe& p : pipes) {
      p.ms.assign(images.size(), {});
      p.cpu.assign(images.size(), {});
      p.found.assign(images.size(), 0);
    }
    for (std::size_t im = 0; im < images.size(); ++im)
      for (int rep = 0; rep < reps; ++rep)
        for (std::size_t k = 0; k < pipes.size(); ++k) {
          Pipe& p = pipes[(k + static_cast<std::size_t>(rep)) % pipes.size()];
          const double c0 = thread_cpu_ms();
          const auto t0 = std::chrono::steady_clock::now();
          p.found[im] = p.run(images[im].gray);
          p.ms[im].push_back(
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          p.cpu[im].push_back(thread_cpu_ms() - c0);
        }
    for (std::size_t im = 0; im <= images.size(); ++im) {
      const bool all = im == images.size();
      auto times = [&](const Pipe& p, bool cpu) {
        const auto& per = cpu ? p.cpu : p.ms;
        if (!all) return per[im];
        std::vector<double> v;  // all images: the per-repetition sum
        for (int r = 0; r < reps; ++r) {
          double s = 0;
          for (const auto& m : per) s += m[static_cast<std::size_t>(r)];
          v.push_back(s);
        }
        return v;
      };
      double anchor_ms = NAN, anchor_cpu = NAN;
      for (const Pipe& p : pipes)
        if (p.anchor) {
          anchor_ms = quantile(times(p, false), 0.5);
          anchor_cpu = quantile(times(p, true), 0.5);
        }
      for (const Pipe& p : pipes) {
        int found = 0;
        for (std::size_t j = 0; j < images.size(); ++j)
          if (all || j == im) found += p.found[j];
        const std::vector<double> t = times(p, false), c = times(p, true);
        std::printf("| %s | %d | %s | %d | %.2f / %.2f | %.3f | %.2f / %.2f | %.3f |\n",
                    all ? "all (sum per repetition)" : images[im].name.c_str(), dec, p.name.c_str(),
                    found, quantile(t, 0.5), quantile(t, 0.99), quantile(t, 0.5) / anchor_ms,
                    quantile(c, 0.5), quantile(c, 0.99), quantile(c, 0.5) / anchor_cpu);
      }
    }
    std::fflush(stdout);
  }
  return 0;
}
