// Silences file descriptor 2 for a scope: OctoMap's .graph and .ot readers and writers print a line per
// scan to stderr (its Debian build keeps OCTOMAP_DEBUG), which would bury the tools' own messages.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>

namespace densemap::tools {

class QuietStderr {
 public:
  QuietStderr() {
    std::fflush(stderr);
    saved_ = dup(2);
    const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (saved_ >= 0 && null >= 0) dup2(null, 2);
    if (null >= 0) close(null);
  }
  ~QuietStderr() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      dup2(saved_, 2);
      close(saved_);
    }
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

}  // namespace densemap::tools
