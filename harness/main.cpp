// `arena`: the Denoise Arena command line. Data flows scene -> sequence -> denoiser -> metrics ->
// report; each subcommand drives one step (or, for `study`, all of them).
#include <iostream>

#include "core/error.hpp"
#include "harness/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Denoise Arena: real-time path-tracing denoisers side by side on identical sequences"};
  app.require_subcommand(1);
  arena::cli::addScenesCommand(app);
  arena::cli::addRenderCommand(app);
  arena::cli::addRefineCommand(app);
  arena::cli::addStudyCommand(app);
  arena::cli::addRunCommands(app);
  arena::cli::addBenchCommand(app);
  arena::cli::addReportCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const arena::Error& e) {
    std::cerr << "arena: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "arena: unexpected error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
