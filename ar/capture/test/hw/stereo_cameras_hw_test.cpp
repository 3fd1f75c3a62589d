// Real cameras (label hw, off by default): two UVC cameras (DENTAR_STEREO_LEFT / _RIGHT, default
// camera:0 / camera:1) or one side-by-side device (DENTAR_STEREO_SBS=/dev/videoN) through
// StereoSource for 3 s: every frame paired, the skew within half a period. Unplug one camera
// during the run (DENTAR_STEREO_UNPLUG=1, 10 s) to see the single-eye fallback and the recovery.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "dentar/ar/stereo_source.h"

namespace dentar::ar {
namespace {

TEST(StereoCamerasHw, PairsFromRealCameras) {
  const char* sbs = std::getenv("DENTAR_STEREO_SBS");
  const std::string l = std::getenv("DENTAR_STEREO_LEFT") ? std::getenv("DENTAR_STEREO_LEFT") : "camera:0";
  const std::string r = std::getenv("DENTAR_STEREO_RIGHT") ? std::getenv("DENTAR_STEREO_RIGHT") : "camera:1";
  auto device = [](const std::string& spec) {
    return spec.rfind("camera:", 0) == 0 ? "/dev/video" + spec.substr(7) : spec;
  };
  if (!sbs && (!std::filesystem::exists(device(l)) || !std::filesystem::exists(device(r))))
    GTEST_SKIP() << "needs two cameras (" << l << ", " << r << ") or DENTAR_STEREO_SBS";
  auto s = sbs ? StereoSource::open_side_by_side(sbs) : StereoSource::open_pair(l, r);
  ASSERT_TRUE(s.ok()) << s.error();
  const double run_s = std::getenv("DENTAR_STEREO_UNPLUG") ? 10.0 : 3.0;
  const double t0 = steady_now_s();
  StereoFrame f;
  while (steady_now_s() - t0 < run_s) (*s)->read(f, 0.2);
  const StereoCaptureStats st = (*s)->stats();
  std::printf("%s\n%s\n", (*s)->description().c_str(), st.summary().c_str());
  EXPECT_GT(st.pairs, 0);
  EXPECT_LE(st.skew_max_ms, 500.0 / (*s)->fps() + 1e-6);
}

}  // namespace
}  // namespace dentar::ar
