// `dentar tags` as a user runs it: the files it writes, --help, and bad arguments (exit 2 with
// a message naming the option or file).
#include <gtest/gtest.h>

#include <filesystem>

#include "dentar/ar/station_scene.h"
#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using dentar::test::CommandResult;

using dentar::test::run_dentar;

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

TEST(TagsCli, WritesThePdfAndSvgOfTheBuiltInStation) {
  const fs::path dir = dentar::test::temp_dir("tags_cli");
  const CommandResult r = run_dentar("tags --out " + (dir / "kit").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string pdf = dentar::test::read_file(dir / "kit" / "station_kit.pdf");
  const std::string svg = dentar::test::read_file(dir / "kit" / "station_kit.svg");
  EXPECT_TRUE(starts_with(pdf, "%PDF-")) << pdf.substr(0, 16);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("width=\"595.275591pt\""), std::string::npos) << svg.substr(0, 300);
  // The built-in station prints on two A4 pages (the pen flag on the second).
  EXPECT_TRUE(fs::exists(dir / "kit" / "station_kit_page2.svg"));
  EXPECT_NE(r.out.find("12 mannequin, 3 mirror and 2 pen tags"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("note:"), std::string::npos) << "the default pen flag fits its tags: " << r.out;
  fs::remove_all(dir);
}

TEST(TagsCli, LetterPaperAndAStationFile) {
  const fs::path dir = dentar::test::temp_dir("tags_cli_letter");
  dentar::ar::StationScene s = dentar::ar::default_station_scene();
  s.name = "my box";
  const fs::path station = dir / "station.json";
  ASSERT_TRUE(dentar::ar::write_station_scene(s, station.string()));
  const CommandResult r =
      run_dentar("tags --station " + station.string() + " --paper letter --out " + (dir / "k").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"my box\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 pages letter"), std::string::npos) << r.out;
  const std::string svg = dentar::test::read_file(dir / "k" / "station_kit.svg");
  EXPECT_NE(svg.find("width=\"612pt\""), std::string::npos) << svg.substr(0, 300);
  EXPECT_NE(dentar::test::read_file(dir / "k" / "station_kit_page2.svg").find("width=\"612pt\""),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "k" / "station_kit_page3.svg"));
  fs::remove_all(dir);
}

TEST(TagsCli, HelpHasASynopsisAndAnExample) {
  const CommandResult r = run_dentar("tags --help");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("Synopsis: dentar tags"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Example:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--paper"), std::string::npos) << r.out;
}

TEST(TagsCli, BadArgumentsExit2WithTheOptionOrFileNamed) {
  const fs::path dir = dentar::test::temp_dir("tags_cli_bad");
  CommandResult r = run_dentar("tags --paper a5 --out " + (dir / "k").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--paper a5"), std::string::npos) << r.out;

  r = run_dentar("tags --station " + (dir / "missing.json").string() + " --out " + (dir / "k").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("missing.json"), std::string::npos) << r.out;

  // A station whose tag cannot fit on the paper.
  dentar::ar::StationScene s = dentar::ar::default_station_scene();
  s.mannequin_tags[2].size_m = 0.15;
  ASSERT_TRUE(dentar::ar::write_station_scene(s, (dir / "big.json").string()));
  r = run_dentar("tags --station " + (dir / "big.json").string() + " --out " + (dir / "k").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("mannequin_tags[2]"), std::string::npos) << r.out;

  // An output folder that cannot be made: the job fails (1) naming the path.
  dentar::test::write_file(dir / "file", "x");
  r = run_dentar("tags --out " + (dir / "file").string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find((dir / "file").string()), std::string::npos) << r.out;

  r = run_dentar("tags --bogus");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(dir / "k"));
  fs::remove_all(dir);
}

}  // namespace
