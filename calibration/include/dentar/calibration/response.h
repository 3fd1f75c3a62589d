// The camera's response curve (grey code -> relative linear light), measured from chessboard
// views during `dentar calibrate camera` (issue 24), and its form in the station file.
//
// Why: a lens and the pixel area blur an edge symmetrically in *linear* light. At the true
// edge between a black and a white square the light is the mean of the two squares' light;
// the grey code there is that mean put through the camera's encoding. With a linear camera
// the code at the edge is halfway between the squares' codes; with an sRGB (gamma-like)
// camera it is above halfway. A chessboard's inner corners are saddle points, found at the
// same place whatever the response (point symmetry), so the straight line between two
// neighbouring corners is the true edge, and the code sampled on it measures the response.
//
// Method: for every edge between two inner corners whose two squares are both bounded by
// inner corners, lo / hi = the median codes near the two squares' centres. For a candidate
// response f (code / 255 -> linear light, f(0) = 0, f(1) = 1), the light along the middle
// half of the edge (bilinear between pixels *in linear light*, which is what the optics
// blurred) relative to the squares', t = (L_edge - f(lo)) / (f(hi) - f(lo)), is 0.5 when f is
// the camera's. The gamma f(u) = u^gamma is fitted to all edges (least squares on t - 0.5);
// its uncertainty is the jackknife over views (views are the independent units: focus,
// exposure, corner error).
// Edges with clipped squares (lo <= 3 or hi >= 250) or contrast below 20 codes are not used.
// Units: grey codes 0..255; pixel coordinates in OpenCV's convention.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dentar/core/result.h"

namespace dentar::calibration {

// One chessboard view: an 8-bit grey image (not owned: must outlive the call) and its inner
// corners, row-major (corner (r, c) at index r * cols + c, as ChessboardSpec lists them).
struct ResponseView {
  const std::uint8_t* gray = nullptr;
  int width = 0, height = 0, stride_bytes = 0;
  std::vector<double> corners_xy;  // x0 y0 x1 y1 ... px
  std::string name;
};

struct ResponseEstimate {
  bool ok = false;
  std::string message;  // why not ok (names the cause: flat, saturated, too few edges)
  double gamma = 1;           // fitted f(u) = u^gamma
  double gamma_sigma = -1;    // jackknife standard error over views
  // RMS of t - 0.5 over the edges for the fitted gamma, linear (gamma 1) and sRGB.
  double rms_gamma = 0, rms_linear = 0, rms_srgb = 0;
  // The named response the data fit as well as the fitted gamma (rms within 5 % + 0.002),
  // "linear" or "srgb"; empty when only the fitted gamma fits.
  std::string named;
  int edges = 0, views = 0;          // edges and views used
  int edges_clipped = 0, edges_flat = 0;  // edges refused, and why
  double median_lo = 0, median_hi = 0;    // the squares' typical codes
};

// Estimates the response from views of a cols x rows inner-corner chessboard. Refused (ok =
// false, message says why and what to do) when the board is flat (white - black contrast
// under 20 codes on most edges), saturated (most edges clipped at 0..3 or 250..255), or fewer
// than 3 views / 60 edges remain.
ResponseEstimate estimate_response_chessboard(const std::vector<ResponseView>& views, int cols,
                                              int rows);

// The response as the station keeps it (docs/formats.md, camera.response).
struct CameraResponseCurve {
  std::string kind;  // "linear", "srgb" or "curve"; empty = unknown
  // kind "curve": 256 entries, code i -> relative linear light in [0, 1], non-decreasing,
  // table[0] < table[255]. Empty otherwise.
  std::vector<double> table;
  double gamma = 0, gamma_sigma = -1;  // the measurement behind it (0 / -1: not measured)
  int views = 0, edges = 0;
  // Empty when valid; else names the field ("camera.response.curve[12] = 0.1 is below
  // curve[11] = 0.2: the curve must not decrease").
  std::string validate(const std::string& field = "camera.response") const;
};

// The station's response from an estimate: the named curve when it fits as well, else the
// fitted gamma as a 256-entry curve.
CameraResponseCurve response_from_estimate(const ResponseEstimate& e);

// sRGB decoding of u in [0, 1] (IEC 61966-2-1).
double srgb_to_linear(double u);

}  // namespace dentar::calibration
