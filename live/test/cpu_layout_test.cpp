// --cpu-layout (issue 28 session 23): the text each thread's CPUs are given in, and its refusals.
#include "dentar/live/cpu_layout.h"

#include <gtest/gtest.h>
#include <sched.h>

#include "dentar/live/live_app.h"

namespace dentar::live {
namespace {

using CL = CpuLayout;

TEST(CpuLayout, RolesCpusRangesAndAll) {
  CpuLayout l;
  ASSERT_EQ(parse_cpu_layout("", 2, l), "");
  EXPECT_TRUE(l.empty());
  EXPECT_EQ(l.text(), "");
  ASSERT_EQ(parse_cpu_layout("engine=1,frame=0,eye=0-1,capture=1,display=0,raster=all,mesher=1", 2, l), "");
  EXPECT_EQ(l.of(CL::kEngine), std::vector<int>({1}));
  EXPECT_EQ(l.of(CL::kFrame), std::vector<int>({0}));
  EXPECT_EQ(l.of(CL::kEye), std::vector<int>({0, 1}));
  EXPECT_EQ(l.of(CL::kCaptureLeft), std::vector<int>({1}));   // capture = both cameras
  EXPECT_EQ(l.of(CL::kCaptureRight), std::vector<int>({1}));
  EXPECT_EQ(l.of(CL::kDisplay), std::vector<int>({0}));
  EXPECT_EQ(l.of(CL::kRaster), std::vector<int>({0, 1}));      // all on 2 CPUs
  EXPECT_EQ(l.text(), "engine=1,frame=0,eye=0+1,capture-l=1,capture-r=1,display=0,raster=0+1,mesher=1");
  // Joined CPUs, repeats dropped, sorted; one role set, the others left to their defaults.
  ASSERT_EQ(parse_cpu_layout("capture-r=3+1+1-2", 4, l), "");
  EXPECT_EQ(l.of(CL::kCaptureRight), std::vector<int>({1, 2, 3}));
  EXPECT_FALSE(l.set(CL::kCaptureLeft));
  EXPECT_FALSE(l.set(CL::kFrame));
  // The text it prints parses back to the same layout.
  CpuLayout back;
  ASSERT_EQ(parse_cpu_layout(l.text(), 4, back), "");
  EXPECT_EQ(back.text(), l.text());
}

TEST(CpuLayout, BadTextRefusedNamingRoleAndValue) {
  CpuLayout l;
  auto err = [&](const std::string& t, int ncpu = 2) { return parse_cpu_layout(t, ncpu, l); };
  EXPECT_NE(err("frame=2").find("frame=2: CPU 2 does not exist: this machine has 2 (0-1)"), std::string::npos)
      << err("frame=2");
  EXPECT_NE(err("gpu=0").find("unknown role \"gpu\""), std::string::npos) << err("gpu=0");
  EXPECT_NE(err("frame").find("\"frame\" must be ROLE=CPUS"), std::string::npos) << err("frame");
  EXPECT_NE(err("frame=").find("frame=: no CPU given"), std::string::npos) << err("frame=");
  EXPECT_NE(err("frame=x").find("\"x\" is not a CPU"), std::string::npos) << err("frame=x");
  EXPECT_NE(err("frame=-1").find("is not a CPU"), std::string::npos) << err("frame=-1");
  EXPECT_NE(err("eye=1-0").find("the range 1-0 runs backwards"), std::string::npos) << err("eye=1-0");
  EXPECT_NE(err("engine=0-1").find("engine=0-1: the engine runs on one CPU"), std::string::npos) << err("engine=0-1");
  EXPECT_NE(err("frame=0,frame=1").find("frame given twice"), std::string::npos) << err("frame=0,frame=1");
  EXPECT_NE(err("capture=1,capture-r=0").find("capture-r given twice"), std::string::npos);
  EXPECT_NE(err("frame=0,").find("\"\" must be ROLE=CPUS"), std::string::npos) << err("frame=0,");
  // Without the machine's count (LiveOptions::validate): syntax only.
  EXPECT_EQ(err("frame=7,raster=all", 0), "");
  EXPECT_EQ(l.of(CL::kRaster), std::vector<int>({-1}));
}

TEST(CpuLayout, LiveOptionsValidateChecksTheSyntax) {
  LiveOptions o;
  EXPECT_EQ(o.cpu_layout, "");
  EXPECT_EQ(o.validate(), "");
  o.cpu_layout = "engine=1,frame=0,capture=1,display=0";
  EXPECT_EQ(o.validate(), "");
  o.cpu_layout = "frame=0;display=0";
  EXPECT_NE(o.validate().find("cpu_layout: frame=0;display=0: \"0;display=0\" is not a CPU"), std::string::npos)
      << o.validate();
}

// The pin takes effect on the calling thread (the CPU this process may use; the mask restored).
TEST(CpuLayout, PinThisThreadSetsItsMask) {
  cpu_set_t before;
  ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof before, &before), 0);
  int first = -1;
  for (int c = 0; c < CPU_SETSIZE && first < 0; ++c)
    if (CPU_ISSET(c, &before)) first = c;
  ASSERT_GE(first, 0);
  ASSERT_TRUE(pin_this_thread({first}));
  cpu_set_t now;
  ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof now, &now), 0);
  EXPECT_EQ(CPU_COUNT(&now), 1);
  EXPECT_TRUE(CPU_ISSET(first, &now));
  EXPECT_TRUE(pin_this_thread({}));  // nothing asked: unchanged
  ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof now, &now), 0);
  EXPECT_EQ(CPU_COUNT(&now), 1);
  ASSERT_EQ(pthread_setaffinity_np(pthread_self(), sizeof before, &before), 0);
}

}  // namespace
}  // namespace dentar::live
