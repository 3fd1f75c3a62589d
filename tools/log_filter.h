// Third-party libraries print their own lines on stderr: FFmpeg (through OpenCV's video I/O),
// libjpeg ("Corrupt JPEG data: ..."), libapriltag ("...(): WRN: Matrix is singular."), and
// OpenCV's own log ("[ WARN:0@0.1] global ..."). DentAR's messages say what went wrong and
// what to do; those lines, printed before them, only confuse. Without `--verbose` they are
// held back: stderr goes through a pipe whose reader passes every other line through at once
// and counts the library lines; with `--verbose` nothing is filtered.
#pragma once

#include <cstddef>
#include <string_view>

namespace dentar::tools {

// True for a line one of the libraries above prints (without its newline).
bool is_library_log_line(std::string_view line);

// Filters fd 2 from construction until finish() (or destruction): DentAR's own lines go
// through in order, library lines are counted and dropped. Start it before any other thread.
class LibraryLogFilter {
 public:
  LibraryLogFilter();
  ~LibraryLogFilter();
  LibraryLogFilter(const LibraryLogFilter&) = delete;
  LibraryLogFilter& operator=(const LibraryLogFilter&) = delete;
  // Restores fd 2, drains the pipe and returns the number of library lines held back.
  std::size_t finish();

 private:
  int saved_fd_ = -1, read_fd_ = -1;
  std::size_t dropped_ = 0;
  bool finished_ = true;
  void* thread_ = nullptr;  // std::thread*
};

}  // namespace dentar::tools
