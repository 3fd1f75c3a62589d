// Plots and the HTML report of an offline run (`dentar offline`), for
// testers: self-contained SVG line plots and histograms (no plotting
// library, no scripts), embedded inline into one HTML page.
//
// Values are plotted in the units the caller gives (the report boundary:
// mm, degrees, ms); labels must say them. Non-finite values are gaps in a
// line (a lost frame), never drawn as zero.
#pragma once
#include <limits>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace dentar::ar {

struct PlotSeries {
  std::string label;          // legend text
  std::vector<double> x, y;   // same length; NaN/inf in y = gap
  std::string colour;         // CSS colour; empty = from the palette
};

struct LinePlot {
  std::string title, x_label, y_label;  // labels carry units: "time (s)"
  std::vector<PlotSeries> series;
  // Optional horizontal reference line (a goal), drawn dashed; NaN = none.
  double goal_y = std::numeric_limits<double>::quiet_NaN();
  std::string goal_label;
  bool y_from_zero = true;  // include 0 in the y range
  int width_px = 760, height_px = 300;
};

// Histogram of samples in `bins` equal bins between the 0.5th and 99.5th
// percentiles (clamped outliers go to the end bins and are counted in the
// caption); median and p99 marked.
struct Histogram {
  std::string title, x_label;
  std::vector<double> samples;  // non-finite samples are ignored
  int bins = 40;
  int width_px = 360, height_px = 240;
};

// SVG text (an <svg> element, no XML prolog) for each kind of plot. Empty
// series or samples give a plot that says "no data" rather than failing.
std::string svg_line_plot(const LinePlot& p);
std::string svg_histogram(const Histogram& h);

// "1, 2, 5 x 10^k" tick positions covering [lo, hi] with about `target` ticks.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

// Percentile (0..100) of the finite values, by linear interpolation; NaN
// when there are none.
double percentile(std::vector<double> v, double pct);

// Minimal HTML escaping for text nodes and attribute values.
std::string html_escape(const std::string& s);

}  // namespace dentar::ar
