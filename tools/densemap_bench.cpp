// densemap-bench: reproduces Table 2.4 (and Tables 2.2, 2.3) on any source. The reference is OctoMap's
// insertPointCloud in a process of its own (densemap-octomap-reference, fed the scans as an OctoMap .graph),
// run beside each method; every method's map is checked against its baseline.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include <octomap/octomap.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/eval/paired_timing.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/map/octree_map.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "densemap/util/retain_freed_memory.h"
#include "quiet_stderr.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// A method's own noise in this run: the interquartile range of its repetitions over their median
/// (quartiles interpolated linearly; 0 with fewer than two). For normal noise that is about 1.8 standard
/// errors of the ratio of two medians of 5, so a smaller difference between two methods is not a measured
/// one.
double relativeSpread(std::vector<double> v) {
  if (v.size() < 2) return 0.0;
  std::sort(v.begin(), v.end());
  auto quantile = [&](double q) {
    const double pos = q * static_cast<double>(v.size() - 1);
    const auto i = static_cast<std::size_t>(pos);
    const double f = pos - static_cast<double>(i);
    return i + 1 < v.size() ? v[i] * (1.0 - f) + v[i + 1] * f : v[i];
  };
  const double m = median(v);
  return m > 0.0 ? (quantile(0.75) - quantile(0.25)) / m : 0.0;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// The scans as an OctoMap .graph in a temporary directory (removed with this object): world-frame clouds,
/// each node's pose the sensor origin with no rotation, so OctoMap maps exactly the points densemap maps.
class ScanGraphFile {
 public:
  explicit ScanGraphFile(const std::vector<cli::WorldScan>& scans, const std::string& keep_as) {
    std::string pattern = (std::filesystem::temp_directory_path() / "densemap-bench-XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw std::runtime_error("cannot create a temporary directory for the scans");
    dir_ = pattern;
    path_ = keep_as.empty() ? (dir_ / "scans.graph").string() : keep_as;
    octomap::ScanGraph graph;
    for (const auto& s : scans) {
      auto cloud = std::make_unique<octomap::Pointcloud>();
      cloud->reserve(s.points.size());
      for (const auto& p : s.points) cloud->push_back(p.x(), p.y(), p.z());
      // ScanGraph takes ownership of the cloud (it deletes its nodes' scans).
      graph.addNode(cloud.release(), octomap::pose6d(s.origin.x(), s.origin.y(), s.origin.z(), 0, 0, 0));
    }
    std::ofstream out(path_, std::ios::binary);
    {
      const tools::QuietStderr quiet;
      graph.writeBinary(out);
    }
    if (!out) throw std::runtime_error("cannot write the scans to " + path_);
  }
  ~ScanGraphFile() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  ScanGraphFile(const ScanGraphFile&) = delete;
  ScanGraphFile& operator=(const ScanGraphFile&) = delete;
  const std::string& path() const { return path_; }
  std::string scratch(const std::string& name) const { return (dir_ / name).string(); }

 private:
  std::filesystem::path dir_;
  std::string path_;
};

std::string shellQuoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct OctomapRun {
  std::unique_ptr<octomap::OcTree> tree;  ///< when asked for (the exactness reference)
  std::vector<double> scan_ms;
  double total_ms = 0.0;
  std::size_t memory_bytes = 0;
};

/// One run of densemap-octomap-reference on the scans: a fresh process, so nothing of this one (OpenMP
/// workers, allocator settings, caches and pages warmed by the previous method) touches OctoMap's time.
OctomapRun runOctomap(const std::string& program, const ScanGraphFile& scans, double res, double max_range,
                      bool want_tree) {
  const std::string tree_path = scans.scratch("reference.ot");
  std::string cmd = shellQuoted(program) + " --graph " + shellQuoted(scans.path()) + " --resolution " +
                    std::to_string(res) + " --max-range " + std::to_string(max_range);
  if (want_tree) cmd += " --write-tree " + shellQuoted(tree_path);
  std::fflush(stdout);
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
  if (!pipe) throw std::runtime_error("cannot run " + program);
  std::string text;
  char buf[4096];
  while (const std::size_t n = std::fread(buf, 1, sizeof buf, pipe.get())) text.append(buf, n);
  if (pclose(pipe.release()) != 0)
    throw std::runtime_error(program + " failed (run it by hand: " + cmd + "); --octomap-reference names it");
  const auto j = nlohmann::json::parse(text);
  OctomapRun r;
  r.scan_ms = j.at("scan_ms").get<std::vector<double>>();
  r.total_ms = j.at("total_ms").get<double>();
  r.memory_bytes = j.at("memory_bytes").get<std::size_t>();
  if (want_tree) {
    std::unique_ptr<octomap::AbstractOcTree> t;
    {
      const tools::QuietStderr quiet;
      t.reset(octomap::AbstractOcTree::read(tree_path));
    }
    auto* tree = dynamic_cast<octomap::OcTree*>(t.get());
    if (!tree) throw std::runtime_error("cannot read back the reference map " + tree_path);
    t.release();
    r.tree.reset(tree);
  }
  return r;
}

std::string defaultReferenceProgram() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("densemap-octomap-reference")
            : (self.parent_path() / "densemap-octomap-reference").string();
}

std::unique_ptr<map::OccupancyMap> makeMap(const std::string& backend,
                                           double res) {  // sweeps: one backend, one resolution
  return map::makeMap({backend, res, {}});
}

struct MethodRun {
  std::unique_ptr<map::OccupancyMap> map;
  update::UpdateStats sum;
  std::vector<double> scan_ms;
  std::string chosen;       ///< with `fastest`: scans per method it ran
  double max_saving = 0.0;  ///< with `fastest`: the largest UpdateStats::super_ray_saving of the scans
};

MethodRun runMethod(const std::vector<cli::WorldScan>& scans, const std::string& backend, double res,
                    const update::UpdateOptions& opt) {
  MethodRun r;
  r.map = makeMap(backend, res);
  update::UpdateEngine engine(opt);
  std::map<update::UpdateMethod, int> ran;
  for (const auto& s : scans) {
    auto st = engine.insert(*r.map, s.points, s.origin);
    if (!st) throw std::runtime_error("scan rejected: sensor origin outside the map");
    ++ran[st->method];
    r.max_saving = std::max(r.max_saving, st->super_ray_saving);
    r.scan_ms.push_back(st->totalMs());
    r.sum.points += st->points;
    r.sum.rays += st->rays;
    r.sum.super_rays += st->super_rays;
    r.sum.grouped_points += st->grouped_points;
    r.sum.traversed += st->traversed;
    r.sum.unnecessary += st->unnecessary;
    r.sum.updated_cells += st->updated_cells;
    r.sum.changed_cells += st->changed_cells;
    r.sum.region_cells += st->region_cells;
    r.sum.fallbacks += st->fallbacks;
    r.sum.generation_ms += st->generation_ms;
    r.sum.update_ms += st->update_ms;
  }
  if (opt.method == update::UpdateMethod::kFastest) {
    // What ran, most scans first (the chooser's own counts leave out the scans it was not asked about).
    std::vector<std::pair<int, update::UpdateMethod>> order;
    for (auto m : update::kAllMethods) order.emplace_back(ran.count(m) ? ran[m] : 0, m);
    std::stable_sort(order.begin(), order.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [count, m] : order)
      r.chosen +=
          (r.chosen.empty() ? "" : ", ") + std::string(update::toString(m)) + " " + std::to_string(count);
  }
  return r;
}

/// Sec. 2.4.2's on-the-fly scenario: scans arrive at `hz`; scans arriving while the mapper is busy are
/// dropped. Uses the measured per-scan times; returns how many scans were used.
std::size_t realtimeUsed(const std::vector<double>& scan_ms, double hz) {
  double t = 0.0;  // seconds
  std::size_t used = 0, next = 0;
  while (next < scan_ms.size()) {
    t = std::max(t, static_cast<double>(next) / hz);
    t += scan_ms[next] / 1000.0;
    ++used;
    next = static_cast<std::size_t>(std::ceil(t * hz - 1e-12));
  }
  return used;
}

bool identicalMaps(const map::OccupancyMap& a, const map::OccupancyMap& b, std::string* why) {
  if (a.backendName() == "grid")
    return static_cast<const map::GridMap&>(a).identical(static_cast<const map::GridMap&>(b), why);
  return map::identicalTrees(static_cast<const map::OctreeMap&>(a).tree(),
                             static_cast<const map::OctreeMap&>(b).tree(), why);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "densemap-bench: update speed of baseline, super rays, culling region and both, beside OctoMap (Table "
      "2.4)"};
  sources::SourceSelection source;
  std::string resolutions = "0.2", backends = "grid,octree", methods = "all", semantics = "batch";
  std::string log_level = "warn";
  double max_range = -1.0, realtime = 0.0;
  int repeat = 1, threads = 0;
  unsigned threshold = 20;
  bool json = false, no_unnecessary = false;
  app.set_config("--config", "", "TOML/INI file with any of these options (flags override it)");
  app.add_option("--resolution", resolutions, "voxel size(s) in metres, comma separated")
      ->capture_default_str();
  app.add_option("--backend", backends, "grid, octree, or both comma separated")->capture_default_str();
  app.add_option("--method", methods,
                 "all (the four and fastest, the default), or a comma list of baseline, superrays, culling, "
                 "superrays+culling, fastest")
      ->capture_default_str();
  app.add_option("--semantics", semantics, "batch or counting")
      ->capture_default_str()
      ->check(CLI::IsMember({"batch", "counting"}));
  app.add_option("--max-range", max_range, "cut rays at this range (<0: unlimited)")->capture_default_str();
  app.add_option("--super-ray-threshold", threshold, "min points per voxel for super rays (k)")
      ->capture_default_str();
  app.add_option(
         "--repeat", repeat,
         "runs per configuration, each starting the methods one further along (a multiple of the "
         "number of methods gives each method every place in the order); medians and median ratios "
         "are reported, and with 2 or more, whether fastest is slower than the best of the four by "
         "more than the best's own interquartile spread over the repeats, and (paired, sign test; 5 or "
         "more repeats can show it) whether it is measurably slower than any of the four")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--realtime", realtime,
                 "also simulate scans arriving at this rate (Hz), dropping those arriving while busy");
  app.add_flag("--json", json, "one JSON object per line instead of a table");
  app.add_flag("--no-unnecessary", no_unnecessary,
               "skip the extra untimed pass that counts unnecessary traversals (Table 2.3) and the distinct "
               "cells the scans change");
  app.add_option("--threads", threads, "worker threads (0 = all cores)")->capture_default_str();
  std::string reference_program = defaultReferenceProgram(), graph_out;
  app.add_option("--octomap-reference", reference_program,
                 "the OctoMap reference program (default: densemap-octomap-reference beside this one)")
      ->capture_default_str();
  bool no_octomap = false;
  app.add_flag("--no-octomap", no_octomap,
               "skip the OctoMap reference runs (no speed-ups; octree maps are checked against the baseline "
               "method): for comparing the methods with each other");
  app.add_option("--graph-out", graph_out,
                 "also keep the scans as this OctoMap .graph (to run densemap-octomap-reference by hand)");
  auto logging_table = cli::loggingOptions(log_level);
  auto source_table = sources::sourceOptionTable(source);
  cli::addToApp(app, {&source_table, &logging_table});
  if (const auto rc = cli::parse(app, argc, argv, {&source_table, &logging_table})) return *rc;
  densemap::util::retainFreedMemory();
  cli::setupLogging(log_level);
  const int used_threads = cli::setThreads(threads);

  try {
    const auto sem = *map::parseSemantics(semantics);
    std::vector<update::UpdateMethod> method_list;
    if (methods == "all") {
      method_list.assign(std::begin(update::kAllMethods), std::end(update::kAllMethods));
      method_list.push_back(update::UpdateMethod::kFastest);
    } else {
      for (const auto& m : splitList(methods)) {
        auto pm = update::parseMethod(m);
        if (!pm)
          throw std::invalid_argument("unknown method '" + m +
                                      "' (baseline, superrays, culling, superrays+culling, fastest)");
        method_list.push_back(*pm);
      }
    }
    // Baseline first: later methods are compared against its map.
    std::sort(method_list.begin(), method_list.end());
    method_list.erase(std::unique(method_list.begin(), method_list.end()), method_list.end());
    std::vector<std::string> backend_list = splitList(backends);
    for (const auto& b : backend_list)
      if (b != "grid" && b != "octree")
        throw std::invalid_argument("unknown backend '" + b + "' (grid, octree)");
    std::vector<double> res_list;
    for (const auto& r : splitList(resolutions)) res_list.push_back(std::stod(r));

    auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    const auto scans = cli::loadScans(*src, range);
    std::unique_ptr<ScanGraphFile> graph;
    if (!no_octomap) graph = std::make_unique<ScanGraphFile>(scans, graph_out);
    std::size_t points = 0;
    for (const auto& s : scans) points += s.points.size();
    const double n = static_cast<double>(scans.size());
    if (!json) {
      std::printf(
          "densemap-bench: %s, scans %zu:%zu (%zu points), %s semantics, max range %g, %d threads, %d "
          "repeat(s)\n",
          src->describe().c_str(), range.first, range.last, points, semantics.c_str(), max_range,
          used_threads, repeat);
    }
    for (double res : res_list) {
      std::vector<double> octo_ms;
      std::unique_ptr<octomap::OcTree> reference;
      struct Acc {
        std::vector<double> total_ms, proc_ms, update_ms, ratio;
        update::UpdateStats stats;
        std::vector<double> scan_ms;
        bool identical = true;
        std::string why;
        std::vector<std::string> chosen;  ///< fastest: what it ran, per repetition
        double max_saving = 0.0;          ///< fastest: the rule's largest input
      };
      std::map<std::pair<std::string, update::UpdateMethod>, Acc> acc;
      std::vector<double> octo_scan_ms;
      std::size_t octo_memory = 0;
      for (int rep = 0; rep < repeat; ++rep) {
        // Each repetition starts the methods one further along, so that no method always runs last: a run's
        // place in the sequence matters on the octree (kitti00 0-59 at 0.1 m: fastest alone 148-152 ms per
        // scan, run fifth 164-165; likely the heap the earlier maps left, not isolated). Every other
        // repetition runs them in reverse, so that no method always runs just after the same other one
        // (rotation alone put fastest just before baseline in 4 of 5 repetitions, and when both run the
        // baseline the second was the faster: 4 of 32 cells "measurably" apart). --repeat N with N a
        // multiple of twice the methods' count gives every method every place and every neighbour.
        std::vector<update::UpdateMethod> order = method_list;
        if (!order.empty()) {
          std::rotate(order.begin(), order.begin() + static_cast<std::ptrdiff_t>((rep / 2) % order.size()),
                      order.end());
          if (rep % 2 == 1) std::reverse(order.begin(), order.end());
        }
        for (const auto& backend : backend_list) {
          std::unique_ptr<map::OccupancyMap> baseline_map;
          for (auto m : order) {
            // Each method run is paired with an OctoMap run just before it (its own process): the pair is
            // seconds apart, so drift of this machine's speed cancels in the ratio.
            OctomapRun o;
            if (graph) o = runOctomap(reference_program, *graph, res, max_range, !reference);
            if (graph) octo_ms.push_back(o.total_ms);
            if (graph && !reference) {
              reference = std::move(o.tree);
              octo_scan_ms = o.scan_ms;
              octo_memory = o.memory_bytes;
            }
            update::UpdateOptions opt;
            opt.method = m;
            opt.semantics = sem;
            opt.max_range = max_range;
            opt.super_rays.threshold = threshold;
            MethodRun r = runMethod(scans, backend, res, opt);
            Acc& a = acc[{backend, m}];
            const double total = r.sum.totalMs();
            a.total_ms.push_back(total);
            a.proc_ms.push_back(r.sum.generation_ms);
            a.update_ms.push_back(r.sum.update_ms);
            if (graph) a.ratio.push_back(o.total_ms / total);
            if (!r.chosen.empty()) a.chosen.push_back(r.chosen);
            a.max_saving = std::max(a.max_saving, r.max_saving);
            if (rep > 0) continue;
            a.stats = r.sum;
            a.scan_ms = r.scan_ms;
            // The reference: OctoMap itself for octree + batch, else this backend's baseline method.
            std::string why;
            if (backend == "octree" && sem == map::UpdateSemantics::kBatch && reference) {
              a.identical =
                  map::identicalTrees(static_cast<map::OctreeMap&>(*r.map).tree(), *reference, &why);
            } else {
              if (!baseline_map) {
                if (m == update::UpdateMethod::kBaseline) {
                  baseline_map = std::move(r.map);
                } else {
                  update::UpdateOptions bo = opt;
                  bo.method = update::UpdateMethod::kBaseline;
                  baseline_map = runMethod(scans, backend, res, bo).map;
                }
              }
              a.identical = r.map ? identicalMaps(*r.map, *baseline_map, &why) : true;
            }
            a.why = why;
          }
        }
      }
      // Table 2.3: unnecessary traversals, counted in a separate untimed pass (needs a lookup per cell).
      if (!no_unnecessary) {
        for (const auto& backend : backend_list)
          for (auto m : method_list) {
            update::UpdateOptions opt;
            opt.method = m;
            opt.semantics = sem;
            opt.max_range = max_range;
            opt.super_rays.threshold = threshold;
            opt.count_unnecessary = true;
            opt.count_cells = true;
            const update::UpdateStats counted = runMethod(scans, backend, res, opt).sum;
            update::UpdateStats& st = acc[{backend, m}].stats;
            st.unnecessary = counted.unnecessary;
            st.updated_cells = counted.updated_cells;
            st.changed_cells = counted.changed_cells;
          }
      }
      const double octo = median(octo_ms);
      if (!graph) {
        if (!json) {
          std::printf("\nresolution %.2f m (no OctoMap reference: --no-octomap)\n", res);
          std::printf("  %-7s %-18s %8s %9s %10s %8s %12s %11s %9s %9s %8s %12s %9s %s\n", "backend",
                      "method", "fps", "proc ms", "update ms", "speedup", "traversed", "changed", "trav/chg",
                      "rays", "pts/ray", "unnecessary", "identical", realtime > 0 ? "realtime" : "");
        }
      } else if (json) {
        nlohmann::json j = {{"method", "octomap"},       {"backend", "octomap"},
                            {"semantics", "batch"},      {"resolution", res},
                            {"scans", scans.size()},     {"points", points},
                            {"fps", 1000.0 * n / octo},  {"proc_ms", 0.0},
                            {"update_ms", octo / n},     {"identical", true},
                            {"speedup_vs_octomap", 1.0}, {"threads", 1},
                            {"repeat", repeat},          {"memory_bytes", octo_memory},
                            {"reference", "own process"}};
        if (realtime > 0) j["realtime_used"] = realtimeUsed(octo_scan_ms, realtime);
        std::printf("%s\n", j.dump().c_str());
      } else {
        std::printf("\nresolution %.2f m: OctoMap insertPointCloud (own process) %.1f ms/scan (%.2f fps)%s\n",
                    res, octo / n, 1000.0 * n / octo,
                    realtime > 0 ? (" realtime used " + std::to_string(realtimeUsed(octo_scan_ms, realtime)) +
                                    "/" + std::to_string(scans.size()))
                                       .c_str()
                                 : "");
        std::printf("  %-7s %-18s %8s %9s %10s %8s %12s %11s %9s %9s %8s %12s %9s %s\n", "backend", "method",
                    "fps", "proc ms", "update ms", "speedup", "traversed", "changed", "trav/chg", "rays",
                    "pts/ray", "unnecessary", "identical", realtime > 0 ? "realtime" : "");
      }
      // The default (fastest) against the best of the four concrete methods, per backend.
      std::map<std::string, std::pair<update::UpdateMethod, double>> best_of_four;
      for (const auto& backend : backend_list)
        for (auto m : method_list) {
          if (m == update::UpdateMethod::kFastest) continue;
          const double t = median(acc[{backend, m}].total_ms);
          auto it = best_of_four.find(backend);
          if (it == best_of_four.end() || t < it->second.second) best_of_four[backend] = {m, t};
        }
      for (const auto& backend : backend_list)
        for (auto m : method_list) {
          const Acc& a = acc[{backend, m}];
          const double total = median(a.total_ms);
          const double ppr =
              a.stats.rays ? static_cast<double>(a.stats.points) / static_cast<double>(a.stats.rays) : 0.0;
          // Cells walked per distinct cell the scans changed: 1 is the limit for any exact method.
          const double per_cell = a.stats.changed_cells ? static_cast<double>(a.stats.traversed) /
                                                              static_cast<double>(a.stats.changed_cells)
                                                        : 0.0;
          if (!a.identical)
            spdlog::error("{} {} map differs from its reference: {}", backend, update::toString(m), a.why);
          // fastest against the best of the four, and whether beyond the best's own spread.
          const bool judged = m == update::UpdateMethod::kFastest && best_of_four.count(backend);
          const auto [best, best_ms] = judged ? best_of_four[backend] : std::pair{m, total};
          const double vs_best = total / best_ms;
          const double spread = judged && repeat > 1 ? relativeSpread(acc[{backend, best}].total_ms) : 0.0;
          const bool slower = vs_best > 1.0 + spread;
          // The unbiased verdict: fastest against each of the four in the same repetitions (sign test).
          std::vector<std::pair<update::UpdateMethod, eval::PairedTiming>> paired;
          if (judged)
            for (auto other : method_list)
              if (other != update::UpdateMethod::kFastest)
                paired.emplace_back(other, eval::comparePaired(a.total_ms, acc[{backend, other}].total_ms));
          if (json) {
            nlohmann::json j = {
                {"method", update::toString(m)},
                {"backend", backend},
                {"semantics", semantics},
                {"resolution", res},
                {"scans", scans.size()},
                {"points", points},
                {"fps", 1000.0 * n / total},
                {"proc_ms", median(a.proc_ms) / n},
                {"update_ms", median(a.update_ms) / n},
                {"traversed", a.stats.traversed},
                {"rays", a.stats.rays},
                {"super_rays", a.stats.super_rays},
                {"points_per_ray", ppr},
                {"points_per_super_ray", a.stats.super_rays ? static_cast<double>(a.stats.grouped_points) /
                                                                  static_cast<double>(a.stats.super_rays)
                                                            : 0.0},
                {"region_cells", a.stats.region_cells},
                {"identical", a.identical},
                {"speedup_vs_octomap", median(a.ratio)},
                {"octomap_ms", octo / n},
                {"threads", used_threads},
                {"repeat", repeat},
                {"total_ms_by_repeat", a.total_ms}};
            if (!no_unnecessary) {
              j["unnecessary"] = a.stats.unnecessary;
              j["updated_cells"] = a.stats.updated_cells;
              j["changed_cells"] = a.stats.changed_cells;
              j["traversed_per_changed_cell"] = per_cell;
            }
            if (!a.chosen.empty()) {
              j["chosen"] = a.chosen;
              j["max_super_ray_saving"] = a.max_saving;
            }
            if (judged) {
              j["best_of_four"] = update::toString(best);
              j["time_vs_best_of_four"] = vs_best;
              if (repeat > 1) {
                j["best_of_four_spread"] = spread;
                j["slower_than_best_beyond_spread"] = slower;
                nlohmann::json vs = nlohmann::json::object(), measurably = nlohmann::json::array();
                for (const auto& [other, t] : paired) {
                  vs[std::string(update::toString(other))] = {{"median_ratio", t.median_ratio},
                                                              {"slower_rounds", t.slower_rounds},
                                                              {"rounds", t.rounds},
                                                              {"p_value", t.p_value}};
                  if (t.measurablySlower()) measurably.push_back(update::toString(other));
                }
                j["paired_vs"] = vs;
                j["measurably_slower_than"] = measurably;
              }
            }
            if (realtime > 0) j["realtime_used"] = realtimeUsed(a.scan_ms, realtime);
            std::printf("%s\n", j.dump().c_str());
          } else {
            std::printf("  %-7s %-18s %8.2f %9.1f %10.1f %7.2fx %12llu %11s %9s %9llu %8.2f %12s %9s %s\n",
                        backend.c_str(), std::string(update::toString(m)).c_str(), 1000.0 * n / total,
                        median(a.proc_ms) / n, median(a.update_ms) / n, median(a.ratio),
                        static_cast<unsigned long long>(a.stats.traversed),
                        no_unnecessary ? "-" : std::to_string(a.stats.changed_cells).c_str(),
                        no_unnecessary ? "-" : fmt::format("{:.2f}", per_cell).c_str(),
                        static_cast<unsigned long long>(a.stats.rays), ppr,
                        no_unnecessary ? "-" : std::to_string(a.stats.unnecessary).c_str(),
                        a.identical ? "yes" : "NO",
                        realtime > 0 ? (std::to_string(realtimeUsed(a.scan_ms, realtime)) + "/" +
                                        std::to_string(scans.size()))
                                           .c_str()
                                     : "");
            if (!a.chosen.empty()) std::printf("          fastest ran: %s\n", a.chosen.back().c_str());
            if (judged) {
              std::printf("          fastest took %.2fx the time of the best of the four (%s)", vs_best,
                          std::string(update::toString(best)).c_str());
              if (repeat > 1)
                std::printf("; %s's own interquartile spread over the %d repeats: %.1f%%, so %s",
                            std::string(update::toString(best)).c_str(), repeat, 100.0 * spread,
                            slower ? "SLOWER beyond the noise" : "within the noise");
              std::printf("\n");
              if (repeat > 1) {
                std::printf(
                    "          paired over the %d repeats (fastest/other, rounds slower, sign test p):",
                    repeat);
                bool any = false;
                for (const auto& [other, t] : paired) {
                  std::printf(" %s %.3f %d/%d p=%.3f%s", std::string(update::toString(other)).c_str(),
                              t.median_ratio, t.slower_rounds, t.rounds, t.p_value,
                              t.measurablySlower() ? " SLOWER" : "");
                  any |= t.measurablySlower();
                }
                std::printf("; %s\n",
                            any ? "measurably slower than one of them" : "not measurably slower than any");
              }
            }
          }
        }
      bool all_identical = true;
      for (const auto& [k, a] : acc) all_identical &= a.identical;
      if (!all_identical) return 3;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
