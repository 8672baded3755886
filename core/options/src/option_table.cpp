#include "densemap/options/option_table.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace densemap::options {

namespace {

std::string tomlQuoted(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string number(double v) {
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".en") == std::string::npos) s += ".0";  // TOML: a float keeps its point
  return s;
}

/// The value as a number, for range checks.
std::optional<double> numeric(const OptionSpec::Target& t) {
  return std::visit(
      [](auto* p) -> std::optional<double> {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, int> || std::is_same_v<T, double> || std::is_same_v<T, std::size_t> ||
                      std::is_same_v<T, std::uint32_t>) {
          return static_cast<double>(*p);
        } else {
          return std::nullopt;
        }
      },
      t);
}

}  // namespace

std::string tomlValue(const OptionSpec::Target& target) {
  return std::visit(
      [](auto* p) -> std::string {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, bool>) {
          return *p ? "true" : "false";
        } else if constexpr (std::is_same_v<T, double>) {
          return number(*p);
        } else if constexpr (std::is_same_v<T, std::string>) {
          return tomlQuoted(*p);
        } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
          std::string out = "[";
          for (std::size_t i = 0; i < p->size(); ++i) out += (i ? ", " : "") + tomlQuoted((*p)[i]);
          return out + "]";
        } else {
          return std::to_string(*p);
        }
      },
      target);
}

OptionSpec& OptionTable::push(std::string name, OptionSpec::Target target, std::string help) {
  OptionSpec& o = options_.emplace_back();
  o.name = std::move(name);
  o.help = std::move(help);
  o.target = target;
  o.default_text = tomlValue(target);
  return o;
}

OptionSpec& OptionTable::add(std::string n, bool& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, int& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, double& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, std::size_t& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, std::uint32_t& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, std::string& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}
OptionSpec& OptionTable::add(std::string n, std::vector<std::string>& v, std::string h) {
  return push(std::move(n), &v, std::move(h));
}

void OptionTable::commit() {
  for (const auto& c : commits_) c();
}

std::string OptionTable::validate() const {
  for (const OptionSpec& o : options_) {
    if (const auto v = numeric(o.target)) {
      if (!std::isfinite(*v) || (o.min && *v < *o.min) || (o.max && *v > *o.max))
        return fmt::format("--{} is {}; it must be in {}..{}", o.name, tomlValue(o.target),
                           o.min ? number(*o.min) : "", o.max ? number(*o.max) : "");
    }
    if (!o.choices.empty()) {
      const auto* s = std::get_if<std::string*>(&o.target);
      if (s != nullptr && std::find(o.choices.begin(), o.choices.end(), **s) == o.choices.end()) {
        std::string list;
        for (const auto& c : o.choices) list += (list.empty() ? "" : ", ") + c;
        return fmt::format("--{} is '{}'; use one of {}", o.name, **s, list);
      }
    }
    if (o.check) {
      if (const std::string why = o.check(); !why.empty()) return "--" + o.name + ": " + why;
    }
  }
  return {};
}

std::string toToml(const std::vector<const OptionTable*>& tables, std::string_view header) {
  std::ostringstream out;
  out << header;
  for (const OptionTable* t : tables) {
    out << "\n# " << t->section() << "\n";
    for (const OptionSpec& o : t->options()) {
      // An empty list is written commented out: CLI11 reads "key = []" as a value-less flag.
      const bool commented = o.example_only || o.default_text == "[]";
      std::string line = (commented ? "# " : "") + o.name + " = " + o.default_text;
      std::string help = o.help;
      if (o.min && o.max) help += fmt::format(" [{}..{}]", *o.min, *o.max);
      if (!o.choices.empty() && help.find(o.choices.front()) == std::string::npos) {
        help += " (";
        for (std::size_t i = 0; i < o.choices.size(); ++i) help += (i ? ", " : "") + o.choices[i];
        help += ")";
      }
      out << line << std::string(line.size() < 34 ? 34 - line.size() : 1, ' ') << "# " << help << "\n";
    }
  }
  return out.str();
}

void finishOptions(std::vector<OptionTable*> tables) {
  for (OptionTable* t : tables) t->commit();
  for (OptionTable* t : tables) {
    if (const std::string why = t->validate(); !why.empty()) throw std::invalid_argument(why);
  }
}

}  // namespace densemap::options
