// ChArUco internals shared by charuco_board.cpp and calib_board.cpp (BoardDetector): OpenCV's
// dictionary and board for a CharucoSpec, built once per detector.
#pragma once

#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>

#include "dentar/ar/calib_board.h"

namespace dentar::ar::detail {

struct CharucoCv;  // OpenCV's dictionary, board and detector parameters (charuco_board.cpp)

// The spec must be valid (CharucoSpec::validate).
std::shared_ptr<CharucoCv> make_charuco_cv(const CharucoSpec& spec);
Result<calibration::BoardView> detect_charuco_with(CharucoCv& cv, const cv::Mat& gray, const CharucoSpec& spec,
                                                   const std::string& name, int min_corners, CharucoStats* stats);

// OpenCV's dictionary for a name ("DICT_4X4_50", "4x4_50", "apriltag_36h11", any case): its
// canonical name and code count, or an empty name when unknown.
struct CharucoDictionary {
  std::string name;
  int id = -1;
  int codes = 0;
};
CharucoDictionary charuco_dictionary(const std::string& name);
// The names accepted, for error messages.
std::string charuco_dictionary_names();

}  // namespace dentar::ar::detail
