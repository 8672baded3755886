#include "densemap/cli/cli_common.h"

#include <omp.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace densemap::cli {

ScanRange parseScanRange(const std::string& text, std::size_t n) {
  if (n == 0) throw std::invalid_argument("the source holds no scans");
  ScanRange r{0, n - 1};
  if (text.empty() || text == "all") return r;
  auto num = [&](const std::string& s) -> std::size_t {
    std::size_t used = 0;
    long v = -1;
    try {
      v = std::stol(s, &used);
    } catch (const std::exception&) {
    }
    if (v < 0 || used != s.size())
      throw std::invalid_argument("bad scan range '" + text + "': expected FIRST:LAST");
    return static_cast<std::size_t>(v);
  };
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    r.first = r.last = num(text);
  } else {
    r.first = colon == 0 ? 0 : num(text.substr(0, colon));
    r.last = colon + 1 == text.size() ? n - 1 : num(text.substr(colon + 1));
  }
  if (r.first > r.last) throw std::invalid_argument("bad scan range '" + text + "': FIRST is after LAST");
  if (r.first >= n)
    throw std::invalid_argument("scan range '" + text + "' starts past the source's " + std::to_string(n) +
                                " scans");
  // An explicit LAST past the end is an error: quietly mapping fewer scans than asked for hides a missing
  // file. "FIRST:" (open end) means "to the last scan".
  if (r.last >= n)
    throw std::invalid_argument("scan range '" + text + "' ends past the source's last scan " +
                                std::to_string(n - 1) + " (" + std::to_string(n) +
                                " scans); give FIRST: to map to the end");
  return r;
}

std::vector<WorldScan> loadScans(const io::ScanSource& source, const ScanRange& range) {
  std::vector<WorldScan> out;
  Progress progress("loading", range.last - range.first + 1);
  for (std::size_t i = range.first; i <= range.last; ++i) {
    const io::Scan s = source.read(i);
    out.push_back({s.worldPoints(), s.origin()});
    progress.step(i - range.first + 1);
  }
  return out;
}

void setupLogging(const std::string& level) {
  // Logs go to stderr: stdout is the programs' output (--json, tables), which scripts parse; a warning
  // there broke a test's JSON (CI at 7a9d9a5).
  if (!spdlog::get("densemap")) spdlog::set_default_logger(spdlog::stderr_color_mt("densemap"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_level(spdlog::level::from_str(level));
}

int setThreads(int threads) {
  if (threads > 0) omp_set_num_threads(threads);
  return omp_get_max_threads();
}

Progress::Progress(std::string label, std::size_t total)
    : label_(std::move(label)), total_(total), tty_(isatty(STDERR_FILENO) != 0) {}

void Progress::step(std::size_t done) {
  if (!tty_) {
    const std::size_t every = total_ < 10 ? 1 : total_ / 10;
    if (total_ >= 10 && (done % every == 0 || done == total_)) spdlog::info("{} {}/{}", label_, done, total_);
    return;
  }
  std::fprintf(stderr, "\r%s %zu/%zu", label_.c_str(), done, total_);
  std::fflush(stderr);
}

Progress::~Progress() {
  if (tty_) std::fprintf(stderr, "\r%*s\r", static_cast<int>(label_.size() + 24), "");
}

}  // namespace densemap::cli
