// SIGINT / SIGTERM handling (interrupt.hpp).
#include "core/interrupt.hpp"

#include <atomic>
#include <csignal>

namespace flapstab {

namespace {

volatile std::sig_atomic_t received = 0;
std::atomic<int> depth{0};
struct sigaction previous_int, previous_term;

extern "C" void on_signal(int s) {
  received = s;
  std::signal(s, SIG_DFL);  // a second signal ends the process
}

}  // namespace

InterruptGuard::InterruptGuard() {
  if (depth++ > 0) return;
  received = 0;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGINT, &sa, &previous_int);
  sigaction(SIGTERM, &sa, &previous_term);
}

InterruptGuard::~InterruptGuard() {
  if (--depth > 0) return;
  sigaction(SIGINT, &previous_int, nullptr);
  sigaction(SIGTERM, &previous_term, nullptr);
}

int interrupt_requested() { return received; }

void clear_interrupt() { received = 0; }

const char* signal_name(int s) {
  switch (s) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    default: return "a signal";
  }
}

}  // namespace flapstab
