// `arena report`: the static HTML dashboard of a run (reports/report.hpp does the work).
#include <iostream>

#include "harness/commands.hpp"
#include "reports/report.hpp"

namespace arena::cli {

void addReportCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("report", "Build a static HTML dashboard (index.html) from a run");
  auto o = std::make_shared<ReportOptions>();
  auto run = std::make_shared<std::string>(), baseline = std::make_shared<std::string>(),
       out = std::make_shared<std::string>();
  cmd->add_option("run", *run, "Run directory (written by `arena run` or `arena sweep`)")
      ->required();
  cmd->add_option("--baseline", *baseline, "A run to compare against: adds the regression view");
  cmd->add_option("--out", *out, "Output directory for index.html and its files")->required();
  cmd->callback([o, run, baseline, out] {
    o->run = *run;
    o->baseline = *baseline;
    o->out = *out;
    ReportSummary s = writeReport(*o);
    std::cout << "report: " << s.index.string() << " (" << s.pairs << " pairs";
    if (s.failedPairs) std::cout << ", " << s.failedPairs << " failed: shown in the report";
    std::cout << ", " << s.imagesCopied << " images)\n";
  });
}

}  // namespace arena::cli
