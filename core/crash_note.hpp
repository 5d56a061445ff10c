#pragma once
// What arena says when foreign code it runs in its own process (a plugin's C functions) kills it
// with a fatal signal. The process cannot go on, and its results are not written; without a word
// the shell says only "Segmentation fault", and nothing names the contender or the frame.
//
// A CrashNote is set around a call into such code: its text, formatted before the call, is what a
// fatal signal (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT) writes to stderr before the process
// dies of that signal as it would have (same exit status, core dump where enabled). exit() called
// while a note is in force writes it too ("arena: fatal: exit() was called <text>"), and the
// process exits with the status it was given. The handlers
// are installed with the first note and chain to those installed before them (a sanitizer's), so a
// crash outside any note is reported as before.
//
// The note is one for the process, set by the harness's thread (the one that calls denoisers):
// a plugin's own worker thread that faults still writes it. The alternate signal stack, which lets
// a stack overflow write its note, is that thread's only; a worker that overflows its stack dies
// without one. Notes nest last in, first out, on that one thread.
#include <string>

namespace arena {

class CrashNote {
 public:
  // `text`: the rest of "arena: fatal: signal 11 (Segmentation fault) <text>". Nested notes
  // replace the outer one while they live (compose it in: outerCrashNote()).
  explicit CrashNote(std::string text);
  ~CrashNote();
  CrashNote(const CrashNote&) = delete;
  CrashNote& operator=(const CrashNote&) = delete;

 private:
  std::string text_;
  const char* outer_;
};

// The text of the note in force ("" when none): what a nested note builds on.
std::string outerCrashNote();

}  // namespace arena
