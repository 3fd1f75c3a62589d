// `dentar live --cpu-layout` (issue 28 session 23): which CPUs each of the live run's threads
// may run on, given by hand, for measuring thread placement (the 2x720p runs are bimodal on a
// 2-core machine and placement is the suspect; docs/BENCHMARKS.md, "Issue 28 session 23").
//
// Text: comma-separated ROLE=CPUS, e.g. "engine=1,frame=0,eye=0,capture=1,display=0,raster=0".
//   CPUS: one CPU ("1"), a range ("0-1"), several joined by '+' ("0+2"), or "all".
//   ROLE (each at most once):
//     engine     the 1 kHz engine's CPU (one CPU; replaces --engine-cpu);
//     frame      the frame thread (tracking, the left eye's composite);
//     eye        the right eye's thread (--eye-threads 2; replaces --eye-thread-cpu);
//     capture    both cameras' capture and decode threads (capture-l / capture-r: one of them;
//                capture-r replaces --capture-right-cpu);
//     display    the main thread: the window's upload, HUD and swap;
//     raster     the window's GL rasteriser (llvmpipe's thread, made when the window opens;
//                the headset's pre-warp; replaces --window-raster-cpu);
//     mesher     the tooth mesher.
// A role not named keeps its default placement (so "" changes nothing). The tag search's
// background thread and the frame thread's own GL rasteriser are not placed by it.
// Checks (clear errors naming the role and value): the syntax; CPU indices below the
// machine's count (resolve()); engine a single CPU.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace dentar::live {

struct CpuLayout {
  enum Role { kEngine, kFrame, kEye, kCaptureLeft, kCaptureRight, kDisplay, kRaster, kMesher, kRoles };
  // Per role: the CPUs (ascending, no repeats); empty: not set (the default placement).
  std::array<std::vector<int>, kRoles> cpus;
  bool set(Role r) const { return !cpus[static_cast<std::size_t>(r)].empty(); }
  const std::vector<int>& of(Role r) const { return cpus[static_cast<std::size_t>(r)]; }
  bool empty() const;
  static const char* name(Role r);
  // The layout as text in the parser's form, every role set ("" when none): for the summary.
  std::string text() const;
};

// Parses `text` into `out` (ncpu <= 0: "all" and indices are not checked against a count; "all"
// then stays unresolved as {-1}). Returns "" or the error, naming the role and value.
std::string parse_cpu_layout(const std::string& text, int ncpu, CpuLayout& out);

// Pins the calling thread to `cpus` (no-op when empty). false when the system refused.
bool pin_this_thread(const std::vector<int>& cpus);

}  // namespace dentar::live
