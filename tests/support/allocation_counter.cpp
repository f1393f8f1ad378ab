#include "support/allocation_counter.hpp"

#include <cstddef>

namespace {
thread_local long g_allocations = 0;
thread_local int g_active = 0;

inline void note_allocation() {
  if (g_active > 0) ++g_allocations;
}
}  // namespace

// GCC says it compiles for ASan with __SANITIZE_ADDRESS__, clang with __has_feature.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CHASLES_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(CHASLES_ASAN)
// Under ASan the sanitizer owns malloc; it offers a hook instead of interposition. Declared here
// because GCC does not ship <sanitizer/allocator_interface.h>.
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void on_malloc(const volatile void*, size_t) { note_allocation(); }
void on_free(const volatile void*) {}
const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
}  // namespace
#else
// Interpose glibc's allocator: every C++ and Eigen allocation ends in one of these.
extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
void __libc_free(void*);

void* malloc(size_t size) {
  note_allocation();
  return __libc_malloc(size);
}
void* calloc(size_t n, size_t size) {
  note_allocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, size_t size) {
  note_allocation();
  return __libc_realloc(p, size);
}
void* memalign(size_t alignment, size_t size) {
  note_allocation();
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(size_t alignment, size_t size) {
  note_allocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, size_t alignment, size_t size) {
  note_allocation();
  void* p = __libc_memalign(alignment, size);
  if (!p) return 12;  // ENOMEM
  *out = p;
  return 0;
}
void free(void* p) { __libc_free(p); }
}
#endif

namespace chasles::testing {

AllocationCounter::AllocationCounter() : start_(g_allocations) { ++g_active; }
AllocationCounter::~AllocationCounter() { --g_active; }
long AllocationCounter::count() const { return g_allocations - start_; }

}  // namespace chasles::testing
