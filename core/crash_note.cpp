#include "core/crash_note.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <mutex>

namespace arena {

namespace {

constexpr int kSignals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
constexpr int kSignalCount = int(sizeof kSignals / sizeof kSignals[0]);

std::atomic<const char*> currentNote{nullptr};
struct sigaction previous[kSignalCount];
std::once_flag installed;

// An alternate stack for the thread that installs the handlers (the harness's), so that a plugin
// overflowing that thread's stack still gets its note written.
alignas(16) char alternateStack[1 << 16];

const char* signalName(int signal) {
  switch (signal) {
    case SIGSEGV:
      return "Segmentation fault";
    case SIGBUS:
      return "Bus error";
    case SIGFPE:
      return "Floating point exception";
    case SIGILL:
      return "Illegal instruction";
    case SIGABRT:
      return "Aborted";
    default:
      return "fatal signal";
  }
}

void writeAll(const char* text) {
  size_t left = std::strlen(text);
  while (left > 0) {
    const ssize_t n = ::write(STDERR_FILENO, text, left);
    if (n <= 0) return;
    text += n;
    left -= size_t(n);
  }
}

// Async-signal-safe: reads the note, writes it, puts back the handler found before ours and lets
// the signal take its course there (a fault recurs on return; a sent signal is raised again).
void onFatalSignal(int signal, siginfo_t* info, void*) {
  int k = 0;
  while (k < kSignalCount && kSignals[k] != signal) ++k;
  if (k < kSignalCount) sigaction(signal, &previous[k], nullptr);
  if (const char* note = currentNote.load()) {
    char number[16];
    int n = 0;
    for (int v = signal; v > 0 && n < 15; v /= 10) number[n++] = char('0' + v % 10);
    char digits[16];
    for (int i = 0; i < n; ++i) digits[i] = number[n - 1 - i];
    digits[n] = '\0';
    writeAll("\narena: fatal: signal ");
    writeAll(digits);
    writeAll(" (");
    writeAll(signalName(signal));
    writeAll(") ");
    writeAll(note);
    writeAll("\n");
  }
  if (!info || info->si_code <= 0) raise(signal);  // sent, not a fault: it would not recur
}

// exit() called while a note is in force (a plugin ending the process from inside a call): said as
// a fatal signal is; the process then exits with the status it was given.
void onExit() {
  if (const char* note = currentNote.load()) {
    writeAll("\narena: fatal: exit() was called ");
    writeAll(note);
    writeAll("\n");
  }
}

void install() {
  std::atexit(onExit);
  stack_t stack{};
  stack.ss_sp = alternateStack;
  stack.ss_size = sizeof alternateStack;
  sigaltstack(&stack, nullptr);
  struct sigaction action {};
  action.sa_sigaction = onFatalSignal;
  action.sa_flags = SA_SIGINFO | SA_ONSTACK;
  sigemptyset(&action.sa_mask);
  for (int k = 0; k < kSignalCount; ++k) sigaction(kSignals[k], &action, &previous[k]);
}

}  // namespace

CrashNote::CrashNote(std::string text) : text_(std::move(text)) {
  std::call_once(installed, install);
  outer_ = currentNote.exchange(text_.c_str());
}

CrashNote::~CrashNote() {
  currentNote.store(outer_);
}

std::string outerCrashNote() {
  const char* note = currentNote.load();
  return note ? note : "";
}

}  // namespace arena
