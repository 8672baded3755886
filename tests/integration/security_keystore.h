// A keystore of the test's own, made by tools/make-security.sh (DENSEMAP_MAKE_SECURITY), for the DDS-Security
// tests of both edges.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "temp_dir.h"

namespace densemap::test {

/// Runs a shell command; a failure fails the test with its output. Returns the output.
inline std::string run(const std::string& command) {
  const std::string out =
      (std::filesystem::temp_directory_path() / ("densemap-sec-" + std::to_string(::getpid()))).string();
  const int rc = std::system((command + " > " + out + " 2>&1").c_str());
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  std::filesystem::remove(out);
  EXPECT_EQ(rc, 0) << command << ":\n" << text.str();
  return text.str();
}

/// tools/make-security.sh DIR with the given arguments.
inline void makeSecurity(const std::filesystem::path& dir, const std::string& args) {
  run(std::string(DENSEMAP_MAKE_SECURITY) + " " + dir.string() + " " + args);
}

/// One keystore per test: a CA, the server, two robots, two clients and the operator.
struct Keystore {
  TempDir tmp;
  std::filesystem::path dir = tmp.path / "keystore";
  explicit Keystore(const std::string& args = "--robots 2 --clients 2") { makeSecurity(dir, args); }
  std::filesystem::path operator/(const std::string& identity) const { return dir / identity; }
  /// A folder of this test's own beside the keystore (one TempDir per test: they are named by the test).
  std::filesystem::path scratch(const std::string& name) const {
    std::filesystem::create_directories(tmp.path / name);
    return tmp.path / name;
  }
};

}  // namespace densemap::test
