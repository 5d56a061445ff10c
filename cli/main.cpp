// `arena`: the Denoise Arena command line. Data flows scene -> sequence -> denoiser -> metrics ->
// report; each subcommand drives one step (or, for `study`, all of them).
#include <OpenEXR/ImfThreading.h>
#include <cxxabi.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>
#include <regex>
#include <thread>
#include <typeinfo>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "denoisers/external/loader.hpp"

namespace {

// The dynamic type of the exception in flight, demangled (std::bad_alloc, Iex_3_1::IoExc, ...).
std::string currentExceptionType() {
  const std::type_info* type = abi::__cxa_current_exception_type();
  if (!type) return "unknown";
  int status = 0;
  char* name = abi::__cxa_demangle(type->name(), nullptr, nullptr, &status);
  std::string out = status == 0 && name ? name : type->name();
  std::free(name);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  // Images of a few MB are allocated and freed every frame (the tracer's 15 frame layers, the
  // denoisers' intermediates). glibc would serve each from fresh mmap pages and return them on free,
  // so every frame paid page faults (5% of `arena bench tracer` in the kernel). Serving them from
  // the heap and keeping freed memory makes the tracer bench about 10% faster; pixels are unchanged.
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  // OpenEXR (de)compresses one file's line blocks on its own threads when it has some; without them
  // every cached frame's ZIP compression ran on one core while the other waited. The bytes are the
  // same whichever thread compresses a block.
  Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency())));
  // An isolated plugin runs in `arena serve`, started from this very executable: /proc/self/exe
  // in the child is the parent's own binary until the exec, even if the file was relinked since.
  arena::setServeExecutable("/proc/self/exe");
  CLI::App app{
      "Denoise Arena: real-time path-tracing denoisers side by side on identical sequences"};
  app.require_subcommand(1);
  // `--help` shows every option's default (subcommands copy these option defaults).
  app.option_defaults()->always_capture_default();
  arena::cli::addScenesCommand(app);
  arena::cli::addRenderCommand(app);
  arena::cli::addRefineCommand(app);
  arena::cli::addStudyCommand(app);
  arena::cli::addRunCommands(app);
  arena::cli::addBenchCommand(app);
  arena::cli::addReportCommand(app);
  arena::cli::addCaptureCommands(app);
  // A misspelt command would read "A subcommand is required": named, with the commands there are.
  if (argc == 1 || argv[1][0] != '-') {
    const std::vector<CLI::App*> commands = app.get_subcommands([](CLI::App*) { return true; });
    std::string names;
    bool known = false;
    for (const CLI::App* c : commands) {
      known = known || (argc > 1 && c->get_name() == argv[1]);
      names += (names.empty() ? "" : ", ") + c->get_name();
    }
    if (!known) {
      std::cerr << "arena: error: "
                << (argc == 1 ? std::string("a command is required")
                              : "unknown command '" + std::string(argv[1]) + "'")
                << "; the commands are: " << names << " (`arena --help` says what each does)\n";
      return 2;
    }
  }
  // No input may end in abort() or an unnamed exception: everything is caught here and named.
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    // --help (and its kind) print and exit 0. A usage error reads as every other bad input does,
    // "arena: error: ...", with where the options are listed; CLI11's own codes (105 for a failed
    // check, 106 for a missing option, ...) would make it look different from every other bad
    // input, so all of them are the documented usage-error code 2 (README "Exit codes").
    if (e.get_exit_code() == 0) return app.exit(e);
    const std::vector<CLI::App*> given = app.get_subcommands();
    // CLI11 says "--scenes: At Most 1 required but received 2" of an option given twice.
    std::string what = e.what();
    const std::string twice = ": At Most 1 required but received ";
    if (const size_t at = what.find(twice); at != std::string::npos && what.rfind("--", 0) == 0) {
      const std::string option = what.substr(0, at);
      const bool list = option == "--scenes" || option == "--denoisers" || option == "--metric" ||
                        option == "--grid";
      what = option + " given " + what.substr(at + twice.size()) + " times; give it once" +
             (list ? " (a list is one comma-separated value, e.g. " + option + " a,b)" : "");
    }
    // CLI11's range check of a whole-number option reads a value it cannot convert as out of range
    // ("--frames: Value 2.5 not in range 2 to 100"): a number inside the range was not whole.
    static const std::regex range(R"(^(--[\w-]+): Value (\S+) not in range (-?\d+) to (-?\d+)$)");
    if (std::smatch m; std::regex_match(what, m, range)) {
      char* end = nullptr;
      const std::string text = m[2];
      const double v = std::strtod(text.c_str(), &end);
      if (end && *end == '\0' && !text.empty() && std::isfinite(v) && v >= std::stod(m[3]) &&
          v <= std::stod(m[4]))
        what = std::string(m[1]) + ": " + text +
               " is not a whole number written in digits; expected one from " + std::string(m[3]) +
               " to " + std::string(m[4]);
    }
    // The innermost subcommand given lists its options (`arena bench --help` lists only benches).
    std::string command;
    for (const CLI::App* sub = given.empty() ? nullptr : given.front(); sub;) {
      command += sub->get_name() + " ";
      const std::vector<CLI::App*> inner = sub->get_subcommands();
      sub = inner.empty() ? nullptr : inner.front();
    }
    std::cerr << "arena: error: " << what << "\n(`arena " << command
              << "--help` lists the options)\n";
    return 2;
  } catch (const arena::Error& e) {
    std::cerr << "arena: error: " << e.what() << "\n";
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {  // names the path(s) and the OS reason
    std::cerr << "arena: error: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "arena: error: out of memory (std::bad_alloc); lower the resolution, frame count "
                 "or the number "
                 "of scenes per run\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "arena: unexpected error (" << currentExceptionType() << "): " << e.what() << "\n";
    return 3;
  } catch (...) {
    std::cerr << "arena: unexpected error: an exception of type " << currentExceptionType() << "\n";
    return 3;
  }
  return 0;
}
