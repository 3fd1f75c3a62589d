// dentar tags: the printable station kit (the station's AprilTags at true scale, the pen flag and
// a 50 mm scale bar) as PDF and SVG. A thin layer over dentar::kit.
#include <filesystem>
#include <iostream>
#include <memory>

#include "commands.h"
#include "dentar/kit/station_kit.h"

namespace dentar::tools {
namespace {

struct TagsCli {
  std::string station;  // --station FILE
  std::string out = "out/kit";
  std::string paper = "a4";
};

int run(const TagsCli& c) {
  const auto paper = kit::parse_paper(c.paper);
  if (!paper) {
    print_error("tags", "--paper " + c.paper + ": must be a4 or letter");
    return 2;
  }
  ar::StationScene station = ar::default_station_scene();
  if (!c.station.empty() && !std::filesystem::is_regular_file(c.station) && ar::builtin_station_scene(c.station)) {
    station = *ar::builtin_station_scene(c.station);
  } else if (!c.station.empty()) {
    auto s = ar::read_station_scene(c.station);
    if (!s) {
      print_error("tags", "--station: " + s.error());
      return 2;
    }
    station = std::move(s).value();
  }
  kit::KitOptions o;
  o.paper = *paper;
  auto files = kit::write_station_kit(station, o, c.out);
  if (!files) {
    print_error("tags", files.error());
    // A station that cannot be printed on this paper is bad input; a folder that cannot be
    // written is a failure of the job.
    return files.error().rfind("station kit:", 0) == 0 ? 2 : 1;
  }
  const kit::KitLayout& L = files->layout;
  int n[3] = {0, 0, 0};
  for (const auto& t : L.tags) ++n[static_cast<int>(t.role)];
  std::cout << "station kit of \"" << station.name << "\" (" << ar::tag_family_name(station.family)
            << "), " << L.pages << (L.pages == 1 ? " page " : " pages ") << kit::paper_name(*paper)
            << ": " << n[0] << " mannequin, " << n[1] << " mirror and " << n[2] << " pen tags, "
            << L.scale_bars.size() << " scale bar" << (L.scale_bars.size() == 1 ? "" : "s")
            << "\nwrote " << files->pdf << "\n";
  for (const auto& s : files->svgs) std::cout << "wrote " << s << "\n";
  for (const auto& note : L.notes) std::cout << "note: " << note << "\n";
  std::cout << "Print at 100 % / actual size, then check that the black bar measures 50 mm.\n";
  return 0;
}

}  // namespace

void add_tags(CLI::App& app, int& exit_code) {
  auto c = std::make_shared<TagsCli>();
  CLI::App* s = app.add_subcommand(
      "tags",
      "Write the printable station kit at true scale: the mannequin tag bundle (to tape onto a\n"
      "box), the mirror tags, the pen flag (front and back, folded around a pen, with the pen's\n"
      "axis and tip mark) and a 50 mm scale bar on every page. PDF (all pages) and SVG (one file\n"
      "per page: station_kit.svg, station_kit_page2.svg, ...).\n"
      "Synopsis: dentar tags [--station FILE] [--out DIR] [--paper a4|letter]");
  s->add_option("--station", c->station,
                "Station scene JSON, or a built-in station: default (phantom head), box (flat tag board)");
  s->add_option("--out", c->out, "Output folder (station_kit.pdf, station_kit.svg)")
      ->capture_default_str();
  s->add_option("--paper", c->paper, "Paper size: a4 or letter")->capture_default_str();
  s->footer(
      "Example:\n"
      "  dentar tags --out out/kit\n"
      "  dentar tags --station my_station.json --paper letter --out out/kit_letter\n"
      "Print out/kit/station_kit.pdf at 100 % (actual size) and check the 50 mm bar.");
  s->callback([c, &exit_code] { exit_code = run(*c); });
}

}  // namespace dentar::tools
