// The option tables on a CLI11 command line: every option becomes a flag and a configuration-file key
// (--config FILE, TOML) with its help and default, and --print-config writes the tables as a TOML file.
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

#include "densemap/options/option_table.h"

namespace densemap::cli {

/// Adds each table's options to `app`, grouped by section; a configuration-file key that is no option is
/// an error.
void addToApp(CLI::App& app, const std::vector<options::OptionTable*>& tables);

/// After `app` parsed: marks each option set on the command line or in the configuration file as given
/// (cli::parse does this; a program that calls app.parse itself calls it before finishOptions).
void markGiven(const CLI::App& app, const std::vector<options::OptionTable*>& tables);

/// Parses the command line (and --config), then commits and validates the tables. Returns the exit code
/// when the program should stop (--help, or a bad option, said on stderr), else nullopt.
std::optional<int> parse(CLI::App& app, int argc, char** argv,
                         const std::vector<options::OptionTable*>& tables);

}  // namespace densemap::cli
