// End-to-end tests of the `dentar` command line: exit codes, messages and
// the files it writes.
#include <gtest/gtest.h>

#include <fstream>

#include "testutil.h"

namespace {

using CmdResult = dentar::test::CommandResult;
using dentar::test::run_dentar;


TEST(Cli, EverySubcommandHasHelpWithSynopsisAndExample) {
  for (const char* sub : {"demo", "tooth", "ct"}) {
    const CmdResult r = run_dentar(std::string(sub) + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.out.find("Synopsis"), std::string::npos) << sub << r.out;
    EXPECT_NE(r.out.find("Example"), std::string::npos) << sub << r.out;
  }
  EXPECT_EQ(run_dentar("--help").code, 0);
}

TEST(Cli, BadArgumentsExitTwoWithAClearMessage) {
  CmdResult r = run_dentar("");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("subcommand is required"), std::string::npos) << r.out;
  r = run_dentar("demo --samples 5");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--samples"), std::string::npos) << r.out;
  r = run_dentar("demo --bur drill");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--bur"), std::string::npos) << r.out;
  r = run_dentar("frobnicate");
  EXPECT_EQ(r.code, 2);
  r = run_dentar("ct --input /nonexistent/volume.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("/nonexistent/volume.json"), std::string::npos) << r.out;
  r = run_dentar("tooth --voxel-mm 0.2 --enamel-mm 9");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("enamel_mm"), std::string::npos) << r.out;
}

TEST(Cli, DemoCutsTheToothWritesAPlyAndReportsRemovedVolume) {
  const auto dir = dentar::test::temp_dir("demo");
  const CmdResult r = run_dentar("demo --simulated --voxel-mm 0.15 --samples 3000 --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* s : {"enamel", "dentin", "pulp", "total", "cut_tooth.ply"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
  // The pulp line either way: the adult molar's pulp (session 19) lies below the demo's 1 s cut.
  EXPECT_TRUE(r.out.find("\npulp exposed") != std::string::npos || r.out.find("\npulp not exposed") != std::string::npos)
      << r.out;
  const std::string ply = dentar::test::read_file(dir / "cut_tooth.ply");
  ASSERT_GT(ply.size(), 1000u);
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply.find("element face"), std::string::npos);
  // The replay of the session log reproduces the live volume...
  EXPECT_NE(r.out.find("(match)"), std::string::npos) << r.out;
  const std::string dlog = dentar::test::read_file(dir / "session.dlog");
  EXPECT_GT(dlog.size(), 100000u);
  // The demo drills with the sample jitter on since session 21 (docs/BENCHMARKS.md, "Haptics
  // session 21"), and its header says so, so a replay cuts the same voxels.
  EXPECT_NE(dlog.substr(0, 20000).find("\"sample_jitter\":true"), std::string::npos);
  // ...and the same run prints the same live hash (deterministic).
  const CmdResult again = run_dentar("demo --simulated --voxel-mm 0.15 --samples 3000 --out " + dir.string());
  auto hash = [](const std::string& s) {
    const auto p = s.find(", live ");
    return p == std::string::npos ? std::string() : s.substr(p, 23);
  };
  EXPECT_NE(hash(r.out), "");
  EXPECT_EQ(hash(r.out), hash(again.out));
}

TEST(Cli, DemoInRealTimeReportsPercentilesAndPriorityAndReplaysExactly) {
  const auto dir = dentar::test::temp_dir("demo_rt");
  const CmdResult r =
      run_dentar("demo --seconds 1 --voxel-mm 0.15 --samples 2000 --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* s : {"real-time priority (SCHED_FIFO):", "step compute p50", "p99.9",
                        "period jitter", "(match)"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
}

TEST(Cli, ToothExportsMeshAndVolumeThatCtReadsBack) {
  const auto dir = dentar::test::temp_dir("tooth");
  const std::string vol = (dir / "density.json").string();
  CmdResult r = run_dentar("tooth --voxel-mm 0.2 --ply " + (dir / "t.ply").string() + " --density " + vol);
  ASSERT_EQ(r.code, 0) << r.out;
  // The density volume is a valid CT-like input: 200 dentin, 250 enamel.
  r = run_dentar("ct --input " + vol + " --thresholds 40,128,225 --ply " + (dir / "ct.ply").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("enamel"), std::string::npos) << r.out;
  EXPECT_GT(dentar::test::read_file(dir / "ct.ply").size(), 1000u);
}

TEST(Cli, CtSegmentsTheRealScan) {
  const auto data = dentar::test::shared_data_dir();
  if (data.empty()) GTEST_SKIP() << "../shared/data is absent: skipping the real CT";
  const auto dir = dentar::test::temp_dir("ct");
  const auto raw = data / "tooth_103x94x161_uint8.raw";
  std::ofstream(dir / "tooth.json")
      << R"({"format":"dentar-raw","version":1,"data":")" << raw.string()
      << R"(","dims":[103,94,161],"type":"uint8","spacing_mm":[0.1,0.1,0.1],"origin_mm":[0,0,0]})";
  const CmdResult r = run_dentar("ct --input " + (dir / "tooth.json").string() + " --ply " +
                    (dir / "ct.ply").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("automatic"), std::string::npos) << r.out;
  EXPECT_GT(dentar::test::read_file(dir / "ct.ply").size(), 10000u);
}

}  // namespace
