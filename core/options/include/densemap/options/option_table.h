// Options declared once: each module lists its options in a table (name, default, range or choices,
// help) bound to the fields of its options struct. The command-line flags, the configuration file's keys,
// --help, the shipped config/server.toml and the validation all come from these tables (nvblox's parameter
// descriptions are the model), so a default or a range is written in one place only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace densemap::options {

/// One option: `name` is the long flag (without "--") and the configuration key.
struct OptionSpec {
  using Target = std::variant<bool*, int*, double*, std::size_t*, std::uint32_t*, std::string*,
                              std::vector<std::string>*>;
  std::string name;
  std::string help;
  Target target;
  std::string default_text;  ///< TOML literal of the value when the option was declared
  std::optional<double> min, max;
  std::vector<std::string> choices;
  /// Extra check of the bound value: empty when fine, else what is wrong.
  std::function<std::string()> check;
  /// Written commented out in the example configuration (no meaningful default, e.g. a file).
  bool example_only = false;
  /// Set on the command line or in the configuration file (filled in by cli::parse).
  bool given = false;

  OptionSpec& range(double lo, double hi) {
    min = lo;
    max = hi;
    return *this;
  }
  OptionSpec& oneOf(std::vector<std::string> values) {
    choices = std::move(values);
    return *this;
  }
  OptionSpec& checkedBy(std::function<std::string()> f) {
    check = std::move(f);
    return *this;
  }
  OptionSpec& exampleOnly() {
    example_only = true;
    return *this;
  }
};

class OptionTable {
 public:
  /// `section` titles the table in --help and in the configuration file.
  explicit OptionTable(std::string section) : section_(std::move(section)) {}
  // Options point into the table (enumerations' names): a table moves, it is never copied.
  OptionTable(OptionTable&&) = default;
  OptionTable& operator=(OptionTable&&) = default;
  OptionTable(const OptionTable&) = delete;
  OptionTable& operator=(const OptionTable&) = delete;

  OptionSpec& add(std::string name, bool& value, std::string help);
  OptionSpec& add(std::string name, int& value, std::string help);
  OptionSpec& add(std::string name, double& value, std::string help);
  OptionSpec& add(std::string name, std::size_t& value, std::string help);
  OptionSpec& add(std::string name, std::uint32_t& value, std::string help);
  OptionSpec& add(std::string name, std::string& value, std::string help);
  OptionSpec& add(std::string name, std::vector<std::string>& value, std::string help);

  /// An enumeration, given and shown by name; `commit()` stores the chosen value into `value`.
  template <class E>
  OptionSpec& addChoice(std::string name, E& value, std::vector<std::pair<std::string, E>> names,
                        std::string help) {
    std::string& text = proxies_.emplace_back();
    std::vector<std::string> choices;
    for (const auto& [n, v] : names) {
      choices.push_back(n);
      if (v == value) text = n;
    }
    commits_.push_back([&value, &text, names] {
      for (const auto& [n, v] : names)
        if (n == text) value = v;
    });
    return add(std::move(name), text, std::move(help)).oneOf(std::move(choices));
  }

  /// Runs `f` after parsing, with the enumerations: for values derived from others (a preset that sets
  /// what was not given).
  void afterParse(std::function<void()> f) { commits_.push_back(std::move(f)); }
  /// Stores enumerations chosen by name into their fields (after parsing).
  void commit();
  /// Empty when every value is within its range, choices and check; else "--name: what is wrong".
  std::string validate() const;

  const std::string& section() const { return section_; }
  const std::deque<OptionSpec>& options() const { return options_; }
  std::deque<OptionSpec>& options() { return options_; }

 private:
  OptionSpec& push(std::string name, OptionSpec::Target target, std::string help);

  std::string section_;
  std::deque<OptionSpec> options_;  // a deque: references handed out stay valid
  std::deque<std::string> proxies_;
  std::vector<std::function<void()>> commits_;
};

/// The value of an option as a TOML literal (true, 3, 0.2, "grid", ["a", "b"]).
std::string tomlValue(const OptionSpec::Target& target);

/// Every table's options as a TOML file: a comment per section, each key = its default # its help.
std::string toToml(const std::vector<const OptionTable*>& tables, std::string_view header);

/// Commits and validates every table; throws std::invalid_argument with the first problem.
void finishOptions(std::vector<OptionTable*> tables);

}  // namespace densemap::options
