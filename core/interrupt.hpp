// SIGINT / SIGTERM as a request to stop at the end of the current step (long runs save a checkpoint first).
//
// An InterruptGuard installs the handlers for its lifetime (nested guards share them); the handler only sets a
// flag and restores the default action, so a second Ctrl-C ends the process at once. Code that can stop cleanly
// polls interrupt_requested() between steps and throws Interrupted (core/errors.hpp) once it has saved its state.
#pragma once

namespace flapstab {

class InterruptGuard {
 public:
  InterruptGuard();
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;
};

// The signal received since the outermost guard was installed (SIGINT or SIGTERM), or 0.
int interrupt_requested();
// Forgets a received signal (tests).
void clear_interrupt();
// The name of a signal number for messages ("SIGINT").
const char* signal_name(int signal);

}  // namespace flapstab
