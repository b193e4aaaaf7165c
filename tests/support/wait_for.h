#pragma once
// Polls a condition until it holds or a deadline passes: for what arrives on another thread
// (DDS samples, matching). Returns whether it held.

#include <chrono>
#include <thread>

namespace epmap::testing {

template <class Pred>
bool WaitFor(Pred done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace epmap::testing
