#include "dentar/ar/gl_handoff.h"

#include <GLES3/gl3.h>

#include <string>

#include "dentar/ar/gl_objects.h"

namespace dentar::ar {
namespace {

GLuint64 to_ns(double s) { return static_cast<GLuint64>(s > 0 ? s * 1e9 : 0); }

// Waits for a fence (made in either context) and deletes it; true when it
// signalled within the timeout. A null fence is complete.
bool wait_and_delete(void* fence, double timeout_s) {
  if (fence == nullptr) return true;
  auto s = static_cast<GLsync>(fence);
  const GLenum r = glClientWaitSync(s, 0, to_ns(timeout_s));
  glDeleteSync(s);
  return r == GL_ALREADY_SIGNALED || r == GL_CONDITION_SATISFIED;
}

void delete_fence(void*& f) {
  if (f != nullptr) glDeleteSync(static_cast<GLsync>(f));
  f = nullptr;
}

}  // namespace

Result<std::unique_ptr<SharedFrameRing>> SharedFrameRing::create(int width, int height) {
  if (width <= 0 || height <= 0 || width > 16384 || height > 16384)
    return Error{"SharedFrameRing: size " + std::to_string(width) + "x" + std::to_string(height) +
                 " is not usable"};
  std::unique_ptr<SharedFrameRing> r(new SharedFrameRing);
  r->w_ = width;
  r->h_ = height;
  // The ring owns the names (deleted in its destructor).
  for (int i = 0; i < kSlots; ++i) {
    r->video_[i] = make_texture_2d(GL_RGBA8, width, height).release();
    r->overlay_[i] = make_texture_2d(GL_RGBA8, width, height).release();
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  // The consumer may bind these names only once they exist in the share group.
  glFlush();
  if (auto e = gl_error_message("SharedFrameRing::create"); !e.empty()) return Error{e};
  return r;
}

SharedFrameRing::~SharedFrameRing() {
  std::lock_guard<std::mutex> lock(m_);
  for (int i = 0; i < kSlots; ++i) {
    delete_fence(ready_[i]);
    delete_fence(released_[i]);
  }
  glDeleteTextures(kSlots, video_);
  glDeleteTextures(kSlots, overlay_);
}

int SharedFrameRing::acquire(double timeout_s) {
  void* fence = nullptr;
  int slot = 0;
  {
    std::lock_guard<std::mutex> lock(m_);
    while (slot == pending_ || slot == shown_) ++slot;  // 3 slots: one is always free
    fence = released_[slot];
    released_[slot] = nullptr;
    delete_fence(ready_[slot]);
    drawing_ = slot;
  }
  if (!wait_and_delete(fence, timeout_s)) {
    std::lock_guard<std::mutex> lock(m_);
    ++stats_.release_timeouts;
  }
  return slot;
}

std::int64_t SharedFrameRing::publish(int slot, std::int64_t tag, int x, int y, int w, int h) {
  GLsync f = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
  glFlush();  // the fence must reach the driver, or the consumer could wait forever
  std::lock_guard<std::mutex> lock(m_);
  std::int64_t replaced = -1;
  if (pending_ >= 0) {
    replaced = tag_[pending_];
    delete_fence(ready_[pending_]);
    ++stats_.replaced;
  }
  delete_fence(ready_[slot]);
  ready_[slot] = f;
  tag_[slot] = tag;
  region_[slot][0] = x;
  region_[slot][1] = y;
  region_[slot][2] = x + w;
  region_[slot][3] = y + h;
  pending_ = slot;
  drawing_ = -1;
  ++stats_.published;
  return replaced;
}

int SharedFrameRing::take(std::int64_t* tag) {
  std::lock_guard<std::mutex> lock(m_);
  if (pending_ < 0) return -1;
  shown_ = pending_;
  pending_ = -1;
  if (tag != nullptr) *tag = tag_[shown_];
  ++stats_.taken;
  return shown_;
}

bool SharedFrameRing::wait_ready(int slot, double timeout_s) {
  void* fence = nullptr;
  {
    std::lock_guard<std::mutex> lock(m_);
    fence = ready_[slot];
    ready_[slot] = nullptr;  // the shown slot: the producer does not touch it
  }
  const bool ok = wait_and_delete(fence, timeout_s);
  if (!ok) {
    std::lock_guard<std::mutex> lock(m_);
    ++stats_.ready_timeouts;
  }
  return ok;
}

void SharedFrameRing::release(int slot) {
  GLsync f = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
  glFlush();
  std::lock_guard<std::mutex> lock(m_);
  delete_fence(released_[slot]);
  released_[slot] = f;
}

SharedFrameRing::Stats SharedFrameRing::stats() const {
  std::lock_guard<std::mutex> lock(m_);
  return stats_;
}

}  // namespace dentar::ar
