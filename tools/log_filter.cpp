#include "log_filter.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <string>
#include <thread>

namespace dentar::tools {

bool is_library_log_line(std::string_view l) {
  auto starts = [&](std::string_view p) { return l.substr(0, p.size()) == p; };
  auto has = [&](std::string_view p) { return l.find(p) != std::string_view::npos; };
  // FFmpeg's av_log: "[mjpeg @ 0x55d0c0a3e2c0] ..." (and its bare continuation lines are rare).
  if (starts("[") && has(" @ 0x") && l.find(']') != std::string_view::npos) return true;
  // OpenCV's log: "[ WARN:0@0.012] global ...", "[ERROR:0@0.1] global ...", "[ INFO:...".
  for (std::string_view p : {"[ WARN:", "[ERROR:", "[ INFO:", "[DEBUG:", "[FATAL:", "[VERBOSE:"})
    if (starts(p)) return true;
  // libjpeg's warnings (emit_message through OpenCV's and FFmpeg's decoders).
  for (std::string_view p : {"Corrupt JPEG data", "Premature end of JPEG file", "Invalid SOS parameters",
                             "Unsupported marker type", "JPEG datastream contains no image",
                             "Not a JPEG file", "Bogus marker length", "Warning: unknown JFIF revision"})
    if (starts(p)) return true;
  // libapriltag's debug_print: "<file>.c:<line>:<function>(): WRN: Matrix is singular."
  if (has("(): WRN: ") || has("(): ERR: ")) return true;
  // libpng through OpenCV: "libpng warning: ..." / "libpng error: ...".
  if (starts("libpng warning:") || starts("libpng error:")) return true;
  // ALSA and OpenAL Soft probing for a sound card (dentar devices, the drill's sound): "ALSA lib
  // pcm.c:2666:(snd_pcm_open_noupdate) Unknown PCM default", "AL lib: (EE) ALCplaybackAlsa_open: ...".
  if (starts("ALSA lib ") || starts("AL lib: ")) return true;
  return false;
}

LibraryLogFilter::LibraryLogFilter() {
  int p[2];
  if (pipe2(p, O_CLOEXEC) != 0) return;
  std::fflush(stderr);
  saved_fd_ = fcntl(2, F_DUPFD_CLOEXEC, 3);
  if (saved_fd_ < 0 || dup2(p[1], 2) < 0) {
    close(p[0]);
    close(p[1]);
    if (saved_fd_ >= 0) close(saved_fd_);
    saved_fd_ = -1;
    return;
  }
  close(p[1]);
  read_fd_ = p[0];
  finished_ = false;
  const int in = read_fd_, out = saved_fd_;
  std::size_t* dropped = &dropped_;
  thread_ = new std::thread([in, out, dropped] {
    std::string line;
    char buf[4096];
    auto emit = [&](bool at_end) {
      std::size_t start = 0;
      for (std::size_t nl; (nl = line.find('\n', start)) != std::string::npos; start = nl + 1) {
        const std::string_view l(line.data() + start, nl - start);
        if (is_library_log_line(l)) {
          ++*dropped;
          continue;
        }
        for (std::size_t off = 0; off <= l.size();) {
          const ssize_t w = write(out, l.data() + off, l.size() + 1 - off);  // with its '\n'
          if (w <= 0) break;
          off += static_cast<std::size_t>(w);
        }
      }
      line.erase(0, start);
      if (at_end && !line.empty()) {
        if (!is_library_log_line(line)) (void)!write(out, line.data(), line.size());
        line.clear();
      }
    };
    for (;;) {
      const ssize_t n = read(in, buf, sizeof buf);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
      emit(false);
    }
    emit(true);
  });
}

std::size_t LibraryLogFilter::finish() {
  if (finished_) return dropped_;
  finished_ = true;
  std::cerr.flush();
  std::fflush(stderr);
  // fd 2 was the pipe's only write end (dentar starts no child processes): restoring it
  // closes the pipe, the reader sees end of file, passes on what is left and ends.
  dup2(saved_fd_, 2);
  auto* t = static_cast<std::thread*>(thread_);
  if (t->joinable()) t->join();
  delete t;
  thread_ = nullptr;
  close(read_fd_);
  close(saved_fd_);
  return dropped_;
}

LibraryLogFilter::~LibraryLogFilter() { (void)finish(); }

}  // namespace dentar::tools
