// Issue 26: one exit-code policy for every subcommand, checked as a table: for each subcommand
// and each fault class (a bad argument, an option out of its range, a missing input, a damaged
// input: station file, session log, database, calibration, password file), the code is 2 (bad
// input or arguments) and the message names the option or the file. The job's own failure is 1
// and success 0 (the other e2e tests cover those). Every row runs in well under a second: each
// fault is found before any work.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <vector>

#include "testutil.h"

namespace {
namespace fs = std::filesystem;

using dentar::test::run_dentar;

struct Fixtures {
  fs::path dir, garbage_json, garbage_dlog, garbage_db, missing, garbage_yaml, passwords;
};

const Fixtures& fixtures() {
  static const Fixtures f = [] {
    Fixtures x;
    x.dir = dentar::test::temp_dir("cli_exit_codes");
    x.garbage_json = x.dir / "station.json";
    std::ofstream(x.garbage_json) << "{\"format\": \"dentar-station\", \"version\": 3, \"mannequin_tags\": 7";
    x.garbage_dlog = x.dir / "session.dlog";
    std::ofstream(x.garbage_dlog, std::ios::binary) << std::string(4096, '\x5a');
    x.garbage_db = x.dir / "school.db";
    std::ofstream(x.garbage_db, std::ios::binary) << std::string(8192, 'x');
    x.garbage_yaml = x.dir / "camera.yaml";
    std::ofstream(x.garbage_yaml) << "%YAML:1.0\ncamera_matrix: [1, 2\n";
    x.passwords = x.dir / "instructors.txt";
    const auto pw = dentar::test::run_command("echo 'correct horse battery staple' | " + std::string(DENTAR_BINARY) +
                                              " serve --passwords " + x.passwords.string() + " --set-password alice 2>&1");
    EXPECT_EQ(pw.code, 0) << pw.out;
    x.missing = x.dir / "no_such_file";
    fs::create_directories(x.dir / "session_dir");
    std::ofstream(x.dir / "session_dir" / "session.dlog", std::ios::binary) << std::string(4096, '\x5a');
    return x;
  }();
  return f;
}

struct Row {
  std::string fault;  // the fault class
  std::string args;   // the command line after `dentar`
  std::string names;  // what the message must name
};

void check(const std::vector<Row>& rows) {
  for (const Row& r : rows) {
    const auto res = run_dentar(r.args + " 2>&1");
    EXPECT_EQ(res.code, 2) << r.fault << ": dentar " << r.args << "\n" << res.out;
    EXPECT_NE(res.out.find(r.names), std::string::npos)
        << r.fault << ": dentar " << r.args << "\nshould name " << r.names << "\n" << res.out;
    // No library's own log line before DentAR's message (they show only with --verbose).
    for (const char* lib : {" @ 0x", "[ WARN:", "[ERROR:", "Corrupt JPEG", "WRN: Matrix"})
      EXPECT_EQ(res.out.find(lib), std::string::npos) << r.args << "\n" << res.out;
  }
}

TEST(CliExitCodes, AnUnknownOptionIsTwoInEverySubcommand) {
  std::vector<Row> rows;
  // Required options given (CLI11 names a missing required option first).
  for (const char* sub : {"demo", "tooth", "ct --input x.json", "synth", "track --input x --out y", "calibrate check",
                          "offline", "score x", "assess", "devices", "tags", "live", "db init --db sqlite:x",
                          "db migrate --db sqlite:x", "db status --db sqlite:x", "db import x --db sqlite:x",
                          "db export --db sqlite:x", "db forward --db sqlite:x", "serve --db sqlite:x --passwords y",
                          "sound render x --out y", "sound materials --out y"})
    rows.push_back({"unknown option", std::string(sub) + " --no-such-option", "--no-such-option"});
  check(rows);
}

TEST(CliExitCodes, AValueOutOfRangeIsTwoWithABoundForPeople) {
  check({{"range", "demo --samples 5", "--samples"},
         {"range", "synth --frames 0 --out /tmp/x", "--frames"},
         {"range", "live --frames -1", "--frames: must be 0 or more, got -1"},
         {"range", "live --seconds -2", "--seconds: must be 0 or more, got -2"},
         {"range", "live --width -640", "--width"},
         {"range", "live --stylus sim --exercise incisor_partial_crown --hand-skill 1.5", "--hand-skill"},
         {"range", "live --stylus sim --exercise incisor_partial_crown --hand-style 4", "--hand-style"},
         {"invalid value", "live --stylus pen --hand-skill 0.5", "give --stylus sim and --exercise"},
         {"range", "calibrate live --seconds -1", "--seconds"},
         {"range", "tags --paper a3", "--paper"},
         {"invalid value", "tooth --voxel-mm 0.2 --enamel-mm 9", "enamel_mm"},
         {"range", "sound render x --out y --volume 150", "--volume"}});
  // No 300-digit bound (CLI11's range with std::numeric_limits<double>::max()).
  const auto r = run_dentar("live --frames -1 2>&1");
  EXPECT_LT(r.out.size(), 400u) << r.out;
  EXPECT_EQ(r.out.find("1797693"), std::string::npos) << r.out;
}

TEST(CliExitCodes, AMissingInputIsTwoInEverySubcommand) {
  const Fixtures& f = fixtures();
  const std::string m = f.missing.string();
  check({{"missing input", "ct --input " + m, m},
         {"missing input", "synth --station " + m + ".json --out " + (f.dir / "s").string(), m},
         {"missing input", "track --input " + m + ".mkv --calib " + m + ".yaml --layout " + m + ".json --out " +
                               (f.dir / "p.jsonl").string(), m},
         {"missing input", "calibrate migrate --station " + m + ".json", m},
         {"missing input", "offline --footage " + m + ".mkv --station " + m + ".json --out " + (f.dir / "o").string(), m},
         {"missing input", "score " + m, m},
         {"missing input", "assess --model " + m + ".json " + m, m},
         {"missing input", "devices --station " + m + ".json", m},
         {"missing input", "tags --station " + m + ".json --out " + (f.dir / "kit").string(), m},
         {"missing input", "live --station " + m + ".json", m},
         {"missing input", "live --camera live:" + m + ".avi", m},
         {"missing input", "live --stylus replay:" + m + ".dlog", m},
         {"missing input", "db status --db sqlite:" + m + ".db", m},
         {"missing input", "db import " + m + " --db sqlite:" + (f.dir / "ok.db").string() + " --student s1", m},
         {"missing input", "serve --db sqlite:" + (f.dir / "ok.db").string() + " --passwords " + m + ".txt", m}});
}

TEST(CliExitCodes, ADamagedStationFileIsTwoInEverySubcommandThatReadsOne) {
  const Fixtures& f = fixtures();
  const std::string st = f.garbage_json.string();
  check({{"damaged station", "synth --station " + st + " --out " + (f.dir / "s").string(), st},
         {"damaged station", "calibrate check --simulate --station " + st, st},
         {"damaged station", "calibrate migrate --station " + st, st},
         {"damaged station", "offline --footage " + f.garbage_dlog.string() + " --station " + st + " --out " +
                                 (f.dir / "o").string(), st},
         {"damaged station", "live --station " + st, st},
         {"damaged station", "devices --station " + st, st},
         {"damaged station", "tags --station " + st + " --out " + (f.dir / "kit").string(), st},
         {"damaged station", "track --input " + f.garbage_dlog.string() + " --calib " + st + " --layout " + st +
                                 " --out " + (f.dir / "p.jsonl").string(), st}});
}

TEST(CliExitCodes, ADamagedDatabaseOrLogIsTwoInEverySubcommand) {
  const Fixtures& f = fixtures();
  const std::string db = "sqlite:" + f.garbage_db.string();
  check({{"damaged database", "db status --db " + db, f.garbage_db.string()},
         {"damaged database", "db migrate --db " + db, f.garbage_db.string()},
         {"damaged database", "db init --db " + db, f.garbage_db.string()},
         {"damaged database", "db export --db " + db, f.garbage_db.string()},
         {"damaged database", "serve --db " + db + " --passwords " + f.passwords.string(), f.garbage_db.string()},
         {"damaged session log", "score " + f.garbage_dlog.string(), f.garbage_dlog.string()},
         {"damaged session log", "db import " + (f.dir / "session_dir").string() + " --db sqlite:" +
                                     (f.dir / "ok.db").string() + " --student s1 --station-id st", "session.dlog"},
         {"damaged session log", "assess --model " + f.garbage_json.string() + " " + f.garbage_dlog.string(),
          f.garbage_json.string()},
         {"damaged CT", "ct --input " + f.garbage_json.string(), f.garbage_json.string()}});
}

// The libraries' own lines are held back, and shown with --verbose (before or after the
// subcommand). Motion JPEG footage cut off mid-frame makes FFmpeg's decoder talk
// ("[mjpeg @ 0x...] overread 8"); the run fails (1: the damage is found while the job runs).
TEST(CliExitCodes, LibraryLogLinesOnlyWithVerbose) {
  const Fixtures& f = fixtures();
  const fs::path avi = f.dir / "camera.avi", cut = f.dir / "cut.avi", station = f.dir / "good_station.json";
  {
    cv::VideoWriter w(avi.string(), cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30,
                      cv::Size(640, 480));
    ASSERT_TRUE(w.isOpened());
    cv::Mat img(480, 640, CV_8UC3);
    cv::RNG rng(7);
    for (int i = 0; i < 30; ++i) {
      rng.fill(img, cv::RNG::UNIFORM, 0, 255);
      w.write(img);
    }
  }
  {
    const std::string bytes = dentar::test::read_file(avi);
    ASSERT_GT(bytes.size(), 60000u);
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 20);  // a frame and a half
  }
  ASSERT_EQ(run_dentar("synth --write-default-station " + station.string()).code, 0);
  const std::string args = "offline --footage " + cut.string() + " --station " + station.string() + " --out " +
                           (f.dir / "cut_run").string() + " --no-score --quiet";
  const auto quiet = run_dentar(args + " 2>&1");
  const auto verbose = run_dentar("--verbose " + args + " 2>&1");
  const auto verbose_after = run_dentar(args + " --verbose 2>&1");
  for (const auto* r : {&quiet, &verbose, &verbose_after}) {
    EXPECT_EQ(r->code, 1) << r->out;
    EXPECT_NE(r->out.find("dentar offline: "), std::string::npos) << r->out;
    EXPECT_NE(r->out.find(cut.filename().string()), std::string::npos) << r->out;
  }
  EXPECT_EQ(quiet.out.find(" @ 0x"), std::string::npos) << quiet.out;
  EXPECT_NE(quiet.out.find("--verbose shows them"), std::string::npos) << quiet.out;
  EXPECT_NE(verbose.out.find("[mjpeg @ 0x"), std::string::npos) << verbose.out;
  EXPECT_NE(verbose_after.out.find("[mjpeg @ 0x"), std::string::npos) << verbose_after.out;
}

// Issue 27 (session 12): dentar lesson's faults, each found before any work: a bad option, a
// mode out of range, a missing or damaged lesson, an unknown exercise, a recording that is not
// a session log. Nothing is written.
TEST(CliExitCodes, LessonFaultsAreTwo) {
  const Fixtures& f = fixtures();
  const std::string m = f.missing.string();
  fs::create_directories(f.dir / "bad_lesson");
  std::ofstream(f.dir / "bad_lesson" / "lesson.json") << "{\"format\": \"dentar-lesson\", \"version\": 1, \"exer";
  check({{"unknown option", "lesson show x --no-such-option", "--no-such-option"},
         {"range", "lesson run " + m + " --mode 6 --out " + (f.dir / "l6").string(), "--mode 6 must be 1..5"},
         {"range", "lesson run " + m + " --mode 2 --student lazy --out " + (f.dir / "l7").string(), "--student 'lazy'"},
         {"missing input", "lesson show " + m, m},
         {"missing input", "lesson run " + m + " --mode 2 --out " + (f.dir / "l8").string(), m},
         {"damaged lesson", "lesson show " + (f.dir / "bad_lesson").string(), "lesson.json: not valid JSON"},
         {"damaged recording", "lesson make " + f.garbage_dlog.string() + " --exercise molar_class1_cavity --out " +
                                   (f.dir / "l9").string(), f.garbage_dlog.string()},
         {"unknown exercise", "lesson make " + f.garbage_dlog.string() + " --exercise molar_class9 --out " +
                                  (f.dir / "l9").string(), "no built-in exercise 'molar_class9'"}});
  for (const char* d : {"l6", "l7", "l8", "l9"}) EXPECT_FALSE(fs::exists(f.dir / d)) << d << " was written";
  // Session 14: the lesson plan and a run from a plan.
  std::ofstream(f.dir / "bad_plan.json") << "{\"version\": 1, \"mode\": 9}";
  const std::string l10 = (f.dir / "l10").string();
  check({{"missing input", "lesson plan " + m, m},
         {"damaged session log", "lesson plan " + f.garbage_dlog.string(), f.garbage_dlog.string()},
         {"bad plan option", "lesson plan --check-every 0 " + m, "--check-every 0: check_every must be >= 1"},
         {"damaged plan", "lesson run " + m + " --plan " + (f.dir / "bad_plan.json").string() + " --out " + l10,
          "field mode = 9 must be 1..5"},
         {"missing plan", "lesson run " + m + " --plan " + m + " --out " + l10, m},
         {"no mode", "lesson run " + m + " --out " + l10, "give --mode 1..5 or --plan PLAN.json"}});
  EXPECT_FALSE(fs::exists(f.dir / "l10")) << "l10 was written";
}

// dentar replay (issue 27, mode 1's window): every fault is found before a window opens.
TEST(CliExitCodes, ReplayRefusesBadInputWithTwo) {
  const Fixtures& f = fixtures();
  const std::string m = f.missing.string();
  fs::create_directories(f.dir / "bad_lesson");
  std::ofstream(f.dir / "bad_lesson" / "lesson.json") << "{\"format\": \"dentar-lesson\", \"version\": 1, \"exer";
  check({{"unknown option", "replay x --no-such-option", "--no-such-option"},
         {"missing input", "replay " + m, m},
         {"damaged session log", "replay " + f.garbage_dlog.string(), f.garbage_dlog.string()},
         {"damaged lesson", "replay " + (f.dir / "bad_lesson").string(), "lesson.json: not valid JSON"},
         {"range", "replay " + m + " --speed 100", "--speed 100.000: must be 0.0625 to 16"},
         {"range", "replay " + m + " --size 10x10", "--size 10x10"}});
}

}  // namespace
