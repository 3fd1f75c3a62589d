// The README as a tested contract (issue 26): every command in a code block of
// README.md is listed here, in the README's order, with what the README says it
// produces. ReadmeContract.EveryCommandIsListed fails when the README gains,
// loses or changes a command that this table does not know, so a README edit
// must come with its check. ReadmeContract.RunsEveryCommandInOrder runs them
// all in a fresh folder as a newcomer would (build/dentar = the built binary),
// using the no-hardware variant the README gives where a command needs a
// device, root or a network service.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "testutil.h"

// contract() names only the fields each step needs.
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace {

namespace fs = std::filesystem;

// A command as it appears in the README: a line of a code block (indented by
// four or more spaces) that starts with one of these words, continuation
// lines (trailing backslash) joined, the trailing "# comment" dropped and the
// blanks collapsed. The synopses of "The `dentar` command line" (lines with
// [options] or a|b) and the folders of "Layout" are not commands to run.
const std::vector<std::string> kCommandStarts = {
    "tools/", "build/", "dentar ", "LD_LIBRARY_PATH=", "sudo ", "apt-get ", "runuser ",
    "ctest ", "cmake ", "CC=", "xvfb-run "};

std::string collapse(const std::string& s) {
  std::string out;
  bool blank = false;
  for (char c : s) {
    if (c == ' ' || c == '\t') {
      blank = true;
      continue;
    }
    if (blank && !out.empty()) out += ' ';
    blank = false;
    out += c;
  }
  return out;
}

std::vector<std::string> readme_commands(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  std::vector<std::string> out;
  bool synopses = false;  // "The `dentar` command line": synopses beside one example
  bool layout = false;    // "Layout": folders
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.rfind("## ", 0) == 0) {
      synopses = l == "## The `dentar` command line";
      layout = l == "## Layout";
    }
    if (layout) continue;
    const auto first = l.find_first_not_of(' ');
    if (first == std::string::npos || first < 4) continue;
    std::string body = l.substr(first);
    const bool is_command = std::any_of(kCommandStarts.begin(), kCommandStarts.end(),
                                        [&](const std::string& p) { return body.rfind(p, 0) == 0; });
    if (!is_command) continue;
    if (synopses && body.find_first_of("[|") != std::string::npos) continue;
    // Join continuation lines.
    while (!body.empty() && body.back() == '\\' && i + 1 < lines.size()) {
      body.pop_back();
      body += " " + lines[++i];
    }
    if (const auto hash = body.find(" #"); hash != std::string::npos) body.resize(hash);
    out.push_back(collapse(body));
  }
  return out;
}

// How the e2e run treats one README command.
struct Step {
  std::string readme;    // the command as the README shows it (collapsed)
  std::string run;       // what is run instead ("" = the README's command as is)
  std::string skip_why;  // not run: why (hardware, root, a server; where it is covered)
  std::vector<std::string> produces;  // files the README says it writes (relative)
  std::string says;                   // a text its output must contain ("" = none)
  std::string stdin_text;             // fed on standard input
  bool window = false;                // opens a window: run under Xvfb
};

// In the README's order. Keep in step with README.md.
const std::vector<Step>& contract() {
  static const std::vector<Step> steps = {
      {.readme = "tools/bootstrap.sh demo",
       .run = "build/dentar offline --out out/offline",
       .produces = {"out/offline/composite.mkv", "out/offline/frames.csv",
                    "out/offline/summary.json", "out/offline/report.html",
                    "out/offline/score.html", "out/offline/score.json",
                    "out/offline/footage/session.dlog"}},
      {.readme = "tools/bootstrap.sh test",
       .skip_why = "the test command itself: CI runs it, and it runs this test"},
      {.readme = "dentar ct --input scan.mhd --ply out/scan.ply",
       .run = "SHARED:build/dentar ct --input tooth.json --ply out/scan.ply",
       .produces = {"out/scan.ply"}},
      {.readme = "build/dentar live --camera camera:0 --station box --stylus pen --no-occlusion",
       .skip_why = "needs a webcam and a pen (hw); its rehearsal without a camera is below"},
      {.readme = "build/dentar synth --frames 150 --resolution 1280x720 --webcam --out out/clip",
       .produces = {"out/clip/camera.avi", "out/clip/video.mkv", "out/clip/station.json",
                    "out/clip/session.dlog", "out/clip/truth.jsonl"}},
      {.readme = "build/dentar live --camera live:out/clip/camera.avi --station out/clip/station.json "
                 "--stylus replay:out/clip/session.dlog --record out/rec",
       .produces = {"out/rec/recording.json", "out/rec/session.dlog", "out/rec/score.json"},
       .window = true},
      {.readme = "build/dentar offline --footage out/rec --out out/rec_offline",
       .produces = {"out/rec_offline/composite.mkv", "out/rec_offline/report.html"}},
      {.readme = "build/dentar synth --station box --frames 150 --resolution 1280x720 --webcam "
                 "--out out/box",
       // Fewer frames than the README (the same code path; the suite's time): the rehearsal plays 2 s.
       .run = "build/dentar synth --station box --frames 60 --resolution 1280x720 --webcam --out out/box",
       .produces = {"out/box/camera.avi", "out/box/station.json", "out/box/session.dlog"}},
      {.readme = "build/dentar live --camera live:out/box/camera.avi --station box "
                 "--stylus replay:out/box/session.dlog --no-occlusion",
       .window = true},
      {.readme = "build/dentar live --camera live:out/clip/camera.avi --station out/clip/station.json "
                 "--output sbs --headset assets/headsets/oculus_rift_dk1.json --display 1 --loupe 3",
       .skip_why = "needs a headset as a second monitor (--display 1); the side-by-side output runs under Xvfb "
                   "in HeadsetXvfb.SideBySideEyesMatchOfflineComposite"},
      {.readme = "build/dentar synth --preset standard --stereo --frames 60 --resolution 640x480 --out out/st",
       // Fewer frames than the README (the same code path; the suite's time).
       .run = "build/dentar synth --preset standard --stereo --frames 8 --resolution 640x480 --out out/st",
       .produces = {"out/st/video.mkv", "out/st/station.json", "out/st/session.dlog", "out/st/truth_right.jsonl"}},
      {.readme = "build/dentar offline --stereo --eye both --footage out/st/video.mkv --station out/st/station.json "
                 "--session out/st/session.dlog --out out/st-eyes",
       .produces = {"out/st-eyes/composite.mkv", "out/st-eyes/composite_right.mkv", "out/st-eyes/summary.json"},
       .says = "right eye: its own composite in 8 frames"},
      {.readme = "build/dentar tags --out out/kit",
       .produces = {"out/kit/station_kit.pdf", "out/kit/station_kit.svg"}},
      {.readme = "build/dentar tags --station my_station.json --out out/kit",
       .run = "build/dentar tags --station out/clip/station.json --out out/kit",
       .produces = {"out/kit/station_kit.pdf"}},
      {.readme = "sudo cp assets/udev/70-dentar.rules /etc/udev/rules.d/",
       .skip_why = "changes the machine's udev rules (root)"},
      {.readme = "sudo udevadm control --reload && sudo udevadm trigger",
       .skip_why = "reloads the machine's udev (root)"},
      {.readme = "build/dentar devices --profiles", .says = "touch"},
      {.readme = "LD_LIBRARY_PATH=build/standin build/dentar devices", .says = "OpenHaptics"},
      {.readme = "dentar synth --preset standard --frames 300 --fps 30 --resolution 1280x720 "
                 "--seed 7 --out out/synth_std",
       // The generator steps below run with 30 frames (the same code paths; 300 frames of
       // 720p took minutes of the suite's time).
       .run = "dentar synth --preset standard --frames 30 --fps 30 --resolution 1280x720 --seed 7 --out out/synth_std",
       .produces = {"out/synth_std/video.mkv", "out/synth_std/truth.jsonl",
                    "out/synth_std/station.json", "out/synth_std/session.dlog",
                    "out/synth_std/synth.json", "out/synth_std/masks/mask_000000.png"}},
      {.readme = "dentar synth --preset hard --frames 150 --out out/synth_hard",
       .run = "dentar synth --preset hard --frames 30 --out out/synth_hard",
       .produces = {"out/synth_hard/video.mkv"}},
      {.readme = "dentar synth --preset mirror --frames 150 --png --out out/synth_mirror",
       .run = "dentar synth --preset mirror --frames 30 --png --out out/synth_mirror",
       .produces = {"out/synth_mirror/frames/frame_000000.png"}},
      {.readme = "dentar synth --preset fast --frames 90 --out out/synth_fast",
       .run = "dentar synth --preset fast --frames 30 --out out/synth_fast",
       .produces = {"out/synth_fast/video.mkv"}},
      {.readme = "dentar synth --frames 90 --resolution 1280x720 --out out/clip",
       .run = "dentar synth --frames 30 --resolution 1280x720 --out out/clip",
       .produces = {"out/clip/video.mkv"}},
      {.readme = "dentar track --input out/clip/video.mkv --layout out/clip/station.json "
                 "--out out/clip/poses.jsonl",
       .produces = {"out/clip/poses.jsonl"}},
      {.readme = "dentar track --input camera:0 --width 1280 --height 720 --calib camera.yaml "
                 "--layout station.json --out live.jsonl",
       .skip_why = "needs a UVC camera (hw)"},
      {.readme = "dentar track --input photos/ --calib camera.yaml --tags --family tag36h11 "
                 "--tag-size-mm 14 --out tags.jsonl",
       .run = "build/dentar synth --frames 3 --png --tag-family tag36h11 --out out/photos_clip && "
              "build/dentar track --input out/photos_clip/frames --calib out/photos_clip/station.json "
              "--tags --family tag36h11 --tag-size-mm 14 --out tags.jsonl",
       .produces = {"tags.jsonl"}},
      {.readme = "dentar calibrate all --simulate --station out/station.json",
       .produces = {"out/station.json"}},
      {.readme = "dentar calibrate check --simulate --station out/station.json", .says = "PASS"},
      {.readme = "dentar calibrate live --camera camera:0 --haptic touch --pedal auto "
                 "--station station.json",
       .skip_why = "needs a camera, a Touch and a pedal (hw); rehearsed below with --haptic sim"},
      {.readme = "dentar synth --board aprilgrid:6x5:24:8 --seed 3 --out out/clip",
       .produces = {"out/clip/video.mkv"}},
      {.readme = "dentar calibrate live --haptic sim --pace 4 --seed 3 --camera live:out/clip/video.mkv "
                 "--station out/s.json",
       .produces = {"out/s.json"},
       .says = "updated out/s.json",  // every step passed (the deep check: live_long)
       .window = true},
      {.readme = "dentar demo --simulated --out out/demo",
       .produces = {"out/demo/session.dlog", "out/demo/cut_tooth.ply"}},
      {.readme = "dentar score out/demo",
       .produces = {"out/demo/score.html", "out/demo/score.json"}},
      {.readme = "dentar assess --generate out/cohort --experts 5 --novices 5 --trials 2 "
                 "--kinematics-only",
       .produces = {"out/cohort/trials.csv", "out/cohort/columns.json"}},
      {.readme = "dentar assess --kinematics out/cohort/trials.csv --columns out/cohort/columns.json "
                 "--cv subject --method skill",
       .says = "person identification"},
      {.readme = "dentar assess --generate out/sessions --experts 2 --novices 2 --trials 1",
       .produces = {"out/sessions/trials.csv"}},
      {.readme = "dentar assess --train out/sessions --cv subject --method skill --save out/model.json",
       .produces = {"out/model.json"}},
      {.readme = "dentar assess --model out/model.json out/demo", .says = "out/demo: "},
      {.readme = "dentar assess --kinematics trials.csv --columns map.json --cv subject",
       .skip_why = "your own kinematics table; the same import runs above on the generated tables"},
      {.readme = "dentar lesson builtin --out lessons",
       .run = "build/dentar lesson builtin --out lessons --exercise molar_class1_cavity",
       .produces = {"lessons/molar_class1_cavity/lesson.json", "lessons/molar_class1_cavity/expert.dlog"}},
      {.readme = "dentar lesson show lessons/molar_class1_cavity", .says = "annotations: "},
      {.readme = "dentar lesson run lessons/molar_class1_cavity --mode 2 --student passive --out run_m2",
       .run = "build/dentar lesson run lessons/molar_class1_cavity --mode 2 --student passive --seconds 5 --out run_m2",
       .produces = {"run_m2/session.dlog", "run_m2/run.json", "run_m2/score.json"},
       .says = "reproduce the run's volume bit-exactly"},
      {.readme = "dentar lesson run lessons/molar_class1_cavity --mode 5 --seconds 2 --out run_m5",
       .produces = {"run_m5/session.dlog", "run_m5/run.json"},
       .says = "mode 5 (hints)"},
      {.readme = "dentar offline --session run_m5/session.dlog --frames 90 --out run_m5_ar",
       .run = "build/dentar offline --session run_m5/session.dlog --frames 66 --resolution 640x480 --no-score --out run_m5_ar",
       .produces = {"run_m5_ar/summary.json", "run_m5_ar/composite.mkv"},
       .says = "expert's tool drawn in"},
      {.readme = "dentar lesson plan run_m2 run_m5 --out plan.json", .produces = {"plan.json"}, .says = "Next: mode"},
      {.readme = "dentar lesson run lessons/molar_class1_cavity --plan plan.json --seconds 5 --out run_next",
       .produces = {"run_next/session.dlog", "run_next/run.json"},
       .says = "plan: Next: mode"},
      {.readme = "dentar replay lessons/molar_class1_cavity",
       .run = "build/dentar replay lessons/molar_class1_cavity --frames 3 --no-vsync --screenshot replay.png",
       .produces = {"replay.png"},
       .window = true},
      {.readme = "dentar replay run_m2/session.dlog --against lessons/molar_class1_cavity --superimpose",
       .run = "build/dentar replay run_m2/session.dlog --against lessons/molar_class1_cavity --superimpose --render against.png",
       .produces = {"against.png"},
       .says = "aligned by DTW"},
      {.readme = "dentar db init --db sqlite:school.db", .produces = {"school.db"}},
      {.readme = "dentar score out/rec", .produces = {"out/rec/score.json"}},
      {.readme = "dentar db import out/rec --db sqlite:school.db --student s042 "
                 "--station-id station-3"},
      {.readme = "dentar db export --db sqlite:school.db --out all.jsonl",
       .produces = {"all.jsonl"}},
      {.readme = "dentar live --camera camera:0 --stylus pen --record out/rec --db "
                 "postgresql://dentar@school-server/dentar --student s042",
       .skip_why = "needs a webcam (hw) and the school's PostgreSQL server"},
      {.readme = "apt-get install -y --no-install-recommends postgresql-15",
       .skip_why = "sets up a school server (root); the store tests run a throwaway PostgreSQL"},
      {.readme = "runuser -u postgres -- createuser dentar",
       .skip_why = "sets up a school server (root)"},
      {.readme = "runuser -u postgres -- createdb -O dentar dentar",
       .skip_why = "sets up a school server (root)"},
      {.readme = "dentar db init --db postgresql://dentar@localhost/dentar",
       .skip_why = "needs the school's PostgreSQL server; the store tests run one"},
      {.readme = "dentar serve --passwords instructors.txt --set-password alice",
       .produces = {"instructors.txt"},
       .stdin_text = "a-long-password-for-alice\n"},
      {.readme = "dentar serve --db sqlite:school.db --passwords instructors.txt --port 8080",
       .run = "SERVE"},
      {.readme = "tools/bootstrap.sh bench",
       .skip_why = "the benchmarks (installs VTK, takes long); not a test"},
      {.readme = "CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DDENTAR_FUZZ=ON "
                 "-DDENTAR_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link,address,undefined",
       .skip_why = "a second build with clang; the fuzz label replays the corpora"},
      {.readme = "cmake --build build-fuzz && build-fuzz/volume/fuzz/fuzz_nrrd volume/fuzz/corpus/fuzz_nrrd",
       .skip_why = "runs a libFuzzer build (see above)"},
  };
  return steps;
}

std::string readme_text() {
  return dentar::test::read_file(fs::path(DENTAR_SOURCE_DIR) / "README.md");
}

TEST(ReadmeContract, EveryCommandIsListed) {
  const auto cmds = readme_commands(readme_text());
  ASSERT_GT(cmds.size(), 20u) << "README.md not found or its code blocks not read";
  std::vector<std::string> listed;
  for (const Step& s : contract()) listed.push_back(s.readme);
  for (const auto& c : cmds)
    EXPECT_NE(std::find(listed.begin(), listed.end(), c), listed.end())
        << "README.md shows a command that tests/readme_test.cpp does not check:\n  " << c
        << "\nAdd it to contract() with what the README says it produces.";
  for (const auto& l : listed)
    EXPECT_NE(std::find(cmds.begin(), cmds.end(), l), cmds.end())
        << "tests/readme_test.cpp checks a command that README.md no longer shows:\n  " << l;
  // The same order as the README (the run depends on it).
  std::vector<std::string> in_readme;
  for (const auto& c : cmds)
    if (std::find(listed.begin(), listed.end(), c) != listed.end() &&
        std::find(in_readme.begin(), in_readme.end(), c) == in_readme.end())
      in_readme.push_back(c);
  std::vector<std::string> in_table;
  for (const auto& l : listed)
    if (std::find(cmds.begin(), cmds.end(), l) != cmds.end()) in_table.push_back(l);
  EXPECT_EQ(in_readme, in_table) << "contract() is not in the README's order";
}

TEST(ReadmeContract, ParserReadsIndentedBlocksContinuationsAndComments) {
  const auto c = readme_commands(
      "text with dentar demo inline\n\n    dentar demo --out x   # a comment\n"
      "       build/dentar live --camera a \\\n          --record b\n"
      "    server { listen 443; }\n## The `dentar` command line\n\n    dentar demo [--x]\n"
      "    dentar db a|b\n    dentar ct --input x\n## Next\n\n    dentar tags\n## Layout\n    tools/ x\n");
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0], "dentar demo --out x");
  EXPECT_EQ(c[1], "build/dentar live --camera a --record b");
  EXPECT_EQ(c[2], "dentar ct --input x");
  EXPECT_EQ(c[3], "dentar tags");
}

int free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  ::close(s);
  return ntohs(a.sin_port);
}

// One GET on 127.0.0.1:port; the status line, or "" when nothing answered.
std::string http_status(int port, const std::string& path) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(s);
    return {};
  }
  const std::string req = "GET " + path + " HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n";
  (void)!::write(s, req.data(), req.size());
  char buf[256] = {};
  const auto n = ::read(s, buf, sizeof buf - 1);
  ::close(s);
  std::string r(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
  return r.substr(0, r.find('\r'));
}

// The README's commands in order, in a fresh folder.
TEST(ReadmeContract, RunsEveryCommandInOrder) {
  const fs::path dir = dentar::test::temp_dir("readme");
  const fs::path bin = fs::path(DENTAR_BINARY);
  fs::create_directory_symlink(bin.parent_path(), dir / "build");
  fs::create_directory_symlink(fs::path(DENTAR_SOURCE_DIR) / "assets", dir / "assets");
  const std::string env = "cd '" + dir.string() + "' && HOME='" + dir.string() +
                          "' DENTAR_CACHE_DIR='" + (dir / "cache").string() +
                          "' DENTAR_STATION_DB=sqlite:'" + (dir / "station.db").string() + "' ";
  const bool have_xvfb = std::system("command -v xvfb-run >/dev/null 2>&1") == 0;
  const fs::path shared = dentar::test::shared_data_dir();
  int ran = 0;
  for (const Step& s : contract()) {
    if (!s.skip_why.empty()) continue;
    std::string cmd = s.run.empty() ? s.readme : s.run;
    if (cmd == "SERVE") {
      const int port = free_port();
      const std::string serve = env + "exec build/dentar serve --db sqlite:school.db --passwords "
                                      "instructors.txt --host 127.0.0.1 --port " +
                                std::to_string(port) + " > serve.log 2>&1 & echo $!";
      const auto pid = dentar::test::run_command(serve);
      std::string status;
      for (int i = 0; i < 100 && status.empty(); ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        status = http_status(port, "/login");
      }
      dentar::test::run_command("kill " + pid.out);
      EXPECT_NE(status.find(" 200"), std::string::npos)
          << s.readme << ": the page did not answer /login: '" << status << "'\n"
          << dentar::test::read_file(dir / "serve.log");
      ++ran;
      continue;
    }
    if (cmd.rfind("SHARED:", 0) == 0) {
      if (shared.empty()) continue;  // ../shared/data absent: the CT step is skipped
      cmd = cmd.substr(7);
      // The README's sidecar for the shared CT, with the path it points at.
      dentar::test::write_file(
          dir / "tooth.json",
          "{\"format\": \"dentar-raw\", \"version\": 1, \"data\": \"" +
              (shared / "tooth_103x94x161_uint8.raw").string() +
              "\", \"dims\": [103, 94, 161], \"type\": \"uint8\", \"spacing_mm\": [0.1, 0.1, 0.1], "
              "\"origin_mm\": [0, 0, 0]}");
    }
    if (cmd.rfind("dentar ", 0) == 0) cmd = "build/" + cmd;
    if (s.window) {
      if (!have_xvfb) {
        if (std::getenv("DENTAR_REQUIRE_GL")) ADD_FAILURE() << "xvfb-run missing for: " << s.readme;
        continue;
      }
      cmd = "xvfb-run -a -s '-screen 0 1280x1024x24' " + cmd;
    }
    std::string full = env + cmd;
    if (!s.stdin_text.empty()) full = "printf '%s' '" + s.stdin_text + "' | (" + full + ")";
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = dentar::test::run_command(full);
    const double sec =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[readme] %5.1f s  exit %d  %s\n", sec, r.code, s.readme.c_str());
    ++ran;
    EXPECT_EQ(r.code, 0) << s.readme << "\n(ran: " << cmd << ")\n" << r.out;
    for (const auto& p : s.produces)
      EXPECT_TRUE(fs::exists(dir / p)) << s.readme << ": the README says it writes " << p;
    if (!s.says.empty()) {
      EXPECT_NE(r.out.find(s.says), std::string::npos) << s.readme << "\n" << r.out;
    }
    if (r.code != 0) break;  // later steps use this one's output
  }
  EXPECT_GT(ran, 20);
}

}  // namespace
