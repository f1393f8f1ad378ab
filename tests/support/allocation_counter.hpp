// Counts heap allocations (malloc, calloc, realloc, aligned allocation, operator new) made by
// the current thread while an AllocationCounter is alive. Used to prove that algorithms and the
// control tick allocate nothing.
#pragma once

namespace chasles::testing {

class AllocationCounter {
 public:
  AllocationCounter();
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;

  /// Allocations since construction.
  long count() const;

 private:
  long start_;
};

}  // namespace chasles::testing
