// Replaces the global operator new to count heap allocations made by the
// calling thread, so a test can check that a real-time path (the 1 kHz engine
// step, the force model) allocates nothing. Include it in exactly one source
// file of a test executable: a replacement operator new is defined once per
// program. Counting per thread leaves out threads the test does not check
// (a stand-in's servo thread, the sound thread).
#pragma once

#include <cstdlib>
#include <new>

namespace dentar::test {
inline thread_local long t_allocations = 0;
// Heap allocations made by this thread so far.
inline long this_thread_allocations() { return t_allocations; }
}  // namespace dentar::test

// GCC 12 pairs the inlined std::free below with `new` expressions and warns
// (-Wmismatched-new-delete): a false positive, the replaced operator new uses malloc.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t n) {
  ++dentar::test::t_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
