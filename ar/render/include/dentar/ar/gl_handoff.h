// SharedFrameRing: composites that stay on the GPU, handed from the frame
// thread (producer: the compositor's EGL context) to the window thread
// (consumer: the window's context, sharing objects with the producer's; see
// egl_context.h "Shared mode"). No pixel crosses the CPU.
//
// Three slots, each a frame as compose_gl leaves it (compositor.h,
// GlFrameTarget): the video (RGBA8, W x H) and the composite inside
// the overlay's region (RGBA8, W x H; row 0 = image top), with that region.
// One slot is being drawn by the producer, one published and not yet taken,
// one shown by the window. Latest wins: a newer publish replaces an untaken
// one (it is counted as replaced and never shown).
//
// Synchronisation with fences (sync objects are shared between the two
// contexts):
//  - publish() puts a fence after the producer's draw commands and flushes;
//    the consumer waits for it (wait_ready(): glClientWaitSync, bounded)
//    before drawing from the texture. A client wait and not glWaitSync:
//    Mesa's llvmpipe does not order a server wait across contexts.
//  - release() puts a fence after the consumer's draws from a texture; the
//    producer waits for it (acquire()) before drawing into that texture again.
//
// Thread/context: create(), acquire(), publish() and the destructor on the
// producer's thread with its context current; take(), wait_ready() and
// release() on the consumer's thread with its context current. The state
// between them is guarded by a mutex (short, never held across a GL wait).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>

#include "dentar/ar/compositor.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

class SharedFrameRing {
 public:
  static constexpr int kSlots = 3;
  // Needs the producer's GLES 3 context current. Errors: bad size, GL failure.
  static Result<std::unique_ptr<SharedFrameRing>> create(int width, int height);
  ~SharedFrameRing();  // producer's context current: deletes textures and fences
  SharedFrameRing(const SharedFrameRing&) = delete;
  SharedFrameRing& operator=(const SharedFrameRing&) = delete;

  int width() const { return w_; }
  int height() const { return h_; }
  // GL names, valid in both contexts.
  GlFrameTarget target(int slot) const { return {video_[slot], overlay_[slot]}; }
  // The region of `slot`'s overlay texture that holds the composite (x0, y0,
  // x1, y1; empty = the frame is the video), as published.
  const int* region(int slot) const { return region_[slot]; }

  // Producer: a slot neither published nor shown, after the consumer's last
  // draw from it has completed (waits up to timeout_s; false = timed out and
  // the slot is used anyway, counted in stats().release_timeouts).
  int acquire(double timeout_s = 1.0);
  // Producer: fence + flush; `slot` becomes the newest published frame with
  // this tag (the caller's frame index) and overlay region (x, y, w, h).
  // Returns the replaced untaken slot's tag, or -1.
  std::int64_t publish(int slot, std::int64_t tag, int x, int y, int w, int h);

  // Consumer: the newest published slot (now shown; the previously shown one
  // becomes free), or -1 when nothing new was published. tag receives its tag.
  int take(std::int64_t* tag = nullptr);
  // Consumer: waits until the producer's draws into `slot` are complete
  // (glClientWaitSync, up to timeout_s); false on timeout.
  bool wait_ready(int slot, double timeout_s = 1.0);
  // Consumer: after drawing from `slot` (e.g. after the buffer swap).
  void release(int slot);

  struct Stats {
    std::int64_t published = 0, taken = 0, replaced = 0;
    std::int64_t ready_timeouts = 0, release_timeouts = 0;
  };
  Stats stats() const;

 private:
  SharedFrameRing() = default;
  int w_ = 0, h_ = 0;
  unsigned video_[kSlots] = {0, 0, 0}, overlay_[kSlots] = {0, 0, 0};
  int region_[kSlots][4] = {};
  mutable std::mutex m_;
  // Per slot: GLsync objects (void*) guarded by m_.
  void* ready_[kSlots] = {nullptr, nullptr, nullptr};    // producer's fence
  void* released_[kSlots] = {nullptr, nullptr, nullptr}; // consumer's fence
  std::int64_t tag_[kSlots] = {-1, -1, -1};
  int pending_ = -1, shown_ = -1, drawing_ = -1;
  Stats stats_;
};

}  // namespace dentar::ar
