// A stepper's per-thread step storage (internal header): ScratchLease<T> hands the calling
// thread's T to one step at a time; a nested step on the same thread (a formulation whose step
// runs another step) gets a T of its own. Allocation reuse only: a step overwrites whatever it
// reads from the T, so no result depends on what an earlier step left there.
#pragma once

#include <memory>

namespace vinci::sim::internal {

template <typename T>
class ScratchLease {
 public:
  ScratchLease() {
    thread_local T shared;
    thread_local bool in_use = false;
    if (!in_use) {
      in_use = true;
      in_use_ = &in_use;
      scratch_ = &shared;
    } else {
      own_ = std::make_unique<T>();
      scratch_ = own_.get();
    }
  }
  ~ScratchLease() {
    if (in_use_ != nullptr) *in_use_ = false;
  }
  ScratchLease(const ScratchLease&) = delete;
  ScratchLease& operator=(const ScratchLease&) = delete;
  T& get() { return *scratch_; }

 private:
  T* scratch_ = nullptr;
  bool* in_use_ = nullptr;
  std::unique_ptr<T> own_;
};

}  // namespace vinci::sim::internal
