// SPDX-License-Identifier: Apache-2.0
// Tells ThreadSanitizer about ordering it cannot see. Debian's libtbb is not built with TSan, so
// the fork/join ordering TBB guarantees (everything before a parallel loop happens before its
// blocks; every block happens before the loop returns) is invisible to it and every parallel
// loop would be reported as racing with its caller. Releases and acquires on a tag's address
// restate exactly those edges, nothing more. No-ops outside TSan builds
// (tools/run-sanitizers.sh tsan).
#pragma once

#if defined(__SANITIZE_THREAD__)
#define SCANPREP_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define SCANPREP_TSAN 1
#endif
#endif

#ifdef SCANPREP_TSAN
extern "C" void __tsan_acquire(void* addr);
extern "C" void __tsan_release(void* addr);
#endif

namespace scanprep {

// Everything this thread did so far happens before whatever a later HappensAfter(tag) follows.
inline void HappensBefore([[maybe_unused]] const void* tag) {
#ifdef SCANPREP_TSAN
  __tsan_release(const_cast<void*>(tag));
#endif
}

inline void HappensAfter([[maybe_unused]] const void* tag) {
#ifdef SCANPREP_TSAN
  __tsan_acquire(const_cast<void*>(tag));
#endif
}

}  // namespace scanprep
