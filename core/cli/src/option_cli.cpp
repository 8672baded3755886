#include "densemap/cli/option_cli.h"

#include <cstdio>

#include <fmt/format.h>

namespace densemap::cli {

void addToApp(CLI::App& app, const std::vector<options::OptionTable*>& tables) {
  // A misspelt key in a configuration file is an error, not an option silently left at its default.
  app.allow_config_extras(CLI::config_extras_mode::error);
  for (options::OptionTable* t : tables) {
    for (options::OptionSpec& o : t->options()) {
      std::string help = o.help;
      if (o.min && o.max) help += fmt::format(" [{}..{}]", *o.min, *o.max);
      if (!o.choices.empty()) {
        help += " {";
        for (std::size_t i = 0; i < o.choices.size(); ++i) help += (i ? "," : "") + o.choices[i];
        help += "}";
      }
      const std::string flag = "--" + o.name;
      CLI::Option* opt = std::visit(
          [&](auto* p) -> CLI::Option* {
            using T = std::remove_pointer_t<decltype(p)>;
            if constexpr (std::is_same_v<T, bool>) {
              return app.add_flag(flag, *p, help);
            } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
              return app.add_option(flag, *p, help)->delimiter(',');
            } else {
              return app.add_option(flag, *p, help)->capture_default_str();
            }
          },
          o.target);
      opt->group(t->section());
    }
  }
}

void markGiven(const CLI::App& app, const std::vector<options::OptionTable*>& tables) {
  for (options::OptionTable* t : tables)
    for (options::OptionSpec& o : t->options())
      if (const CLI::Option* opt = app.get_option_no_throw("--" + o.name)) o.given = opt->count() > 0;
}

std::optional<int> parse(CLI::App& app, int argc, char** argv,
                         const std::vector<options::OptionTable*>& tables) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  markGiven(app, tables);
  try {
    options::finishOptions(tables);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s: %s (see --help)\n", app.get_name().empty() ? argv[0] : app.get_name().c_str(),
                 e.what());
    return 2;
  }
  return std::nullopt;
}

}  // namespace densemap::cli
