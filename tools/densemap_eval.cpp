// densemap-eval: the held-out evaluation of Sec. 2.4.2 for the exact log-odds map, the BGK baseline and
// AKIMap: ROC AUC, MSE, accuracy on occupied and free test points, coverage and time per scan.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/dense/adaptive_kernel_layer.h"
#include "densemap/dense/dense_layer_factory.h"
#include "densemap/dense/isotropic_kernel_layer.h"
#include "densemap/densify/densify_dataset.h"
#include "densemap/densify/iln_upsampler.h"
#include "densemap/densify/model_files.h"
#include "densemap/eval/classification_metrics.h"
#include "densemap/eval/held_out.h"
#include "densemap/map/grid_map.h"
#include "densemap/map/map_factory.h"
#include "densemap/sources/open_source.h"
#include "densemap/update/update_engine.h"
#include "densemap/util/image.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;

namespace {

struct SplitScan {
  std::vector<geometry::Vec3f> map_points;
  geometry::Vec3f origin;
};

struct MethodResult {
  std::string method;
  double usage = 1.0;  ///< share of each scan's map points used
  eval::ClassificationScores scores;
  double seconds = 0;
  std::size_t scans = 0;
  std::vector<std::optional<float>> predictions;  ///< per test point (nullopt: unknown)
};

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-eval: held-out evaluation (80% of each scan maps, 20% tests) of occupancy methods"};
  sources::SourceSelection source;
  std::string methods_text = "exact,bgk,akimap", roc_csv, log_level = "warn";
  // The kernel layers' options are the server's table; the held-out protocol samples free space per
  // dense cell (free voxel 0), where the server's default thins it to 0.3 m for 64-beam scans.
  dense::DenseLayerOptions kernel_options;
  kernel_options.free_voxel_size = 0.0;
  // The map and update options are the shared tables (also the kernel layers' cell size and ray cut).
  map::MapOptions map_options;
  map_options.resolution = 0.1;
  update::UpdateOptions update_options;
  bool as_json = false, equal_time = false;
  std::string roc_png, predictions_csv;
  int threads = 0, beam_step = 0;
  std::uint64_t seed = 1;
  std::string densify_method = "none", densify_weights;
  app.add_option("--methods", methods_text, "comma-separated: exact, bgk, akimap")->capture_default_str();
  app.add_option("--seed", seed, "seed of the split, the test points and the free samples")
      ->capture_default_str();
  app.add_option("--roc-csv", roc_csv, "write the ROC curves (method,threshold,fpr,tpr) to this CSV file");
  app.add_flag("--json", as_json, "print one JSON object per method");
  app.add_flag(
      "--equal-time", equal_time,
      "also run slower kernel methods on less data (5% steps) until they fit the fastest one's time");
  app.add_option("--roc-png", roc_png, "plot the ROC curves to this PNG (exact blue, bgk green, akimap red)");
  app.add_option("--predictions-csv", predictions_csv,
                 "write every test point (x,y,z,occupied) with each method's probability (empty: unknown)");
  app.add_option("--threads", threads, "worker threads (0 = all cores)")->capture_default_str();
  app.add_option(
         "--keep-every-nth-beam", beam_step,
         "sparse-LiDAR protocol (Sec. 4.4.5): maps get every n-th beam of each scan's 64-beam range image "
         "(4: 16 beams); the test points are held out from the other beams only (0: off)")
      ->capture_default_str();
  app.add_option(
         "--densify", densify_method,
         "with --keep-every-nth-beam: none (the sparse beams as they are), bilinear or iln (re-sampled "
         "to the full beam layout before mapping)")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "bilinear", "iln"}));
  app.add_option("--densify-weights", densify_weights, "ILN weights (default models/iln/iln_compact.pt)");
  auto map_table = map::mapOptionTable(map_options);
  auto update_table = update::updateOptionTable(update_options);
  auto logging_table = cli::loggingOptions(log_level);
  auto source_table = sources::sourceOptionTable(source);
  auto kernel_table = dense::kernelLayerOptionTable(kernel_options);
  cli::addToApp(app, {&source_table, &map_table, &update_table, &kernel_table, &logging_table});
  if (const auto rc = cli::parse(app, argc, argv,
                                 {&source_table, &map_table, &update_table, &kernel_table, &logging_table}))
    return *rc;
  const double resolution = map_options.resolution, max_range = update_options.max_range;
  cli::setupLogging(log_level);
  if (map_options.decay.enabled()) {
    spdlog::error("--decay-s: the held-out evaluation maps without decay (its scans have no times); drop it");
    return 2;
  }
  cli::setThreads(threads);

  try {
    auto src = sources::openSource(source.source, source.options);
    const auto range = cli::parseScanRange(source.scans, src->size());
    // The split is drawn once, so every method sees the same map points and is tested on the same points.
    std::mt19937_64 rng(seed);
    eval::HeldOutOptions ho;
    ho.end_margin = 0.5 * resolution;
    ho.max_range = max_range;
    std::vector<SplitScan> split;
    std::vector<geometry::Vec3f> test_points;
    std::vector<bool> labels;
    std::unique_ptr<densify::RangeUpsampler> upsampler;
    if (densify_method == "bilinear") upsampler = std::make_unique<densify::BilinearUpsampler>();
    if (densify_method == "iln") {
      densify::IlnUpsampler::setThreads(std::max(1, threads == 0 ? 2 : threads));
      upsampler = std::make_unique<densify::IlnUpsampler>(
          densify::IlnUpsampler::load(densify_weights.empty() ? densify::shippedWeights() : densify_weights));
    }
    if (upsampler && beam_step < 2)
      throw std::invalid_argument("--densify needs --keep-every-nth-beam 2 or more");
    double densify_ms = 0;
    for (std::size_t i = range.first; i <= range.last; ++i) {
      const io::Scan s = src->read(i);
      if (beam_step < 2) {
        auto h = eval::splitScan(s.worldPoints(), s.origin(), ho, rng);
        split.push_back({std::move(h.map_points), s.origin()});
        for (const auto& t : h.tests) {
          test_points.push_back(t.p);
          labels.push_back(t.occupied);
        }
        continue;
      }
      // Sparse-LiDAR protocol: the map sees every n-th beam (raw or densified); the tests are the usual 20%
      // drawn from the other beams' real points, which no map saw.
      const densify::LidarGeometry g = s.lidar.value_or(densify::LidarGeometry{});
      const auto pair = densify::exampleFromScan(s, g, beam_step);
      densify::RangeImage others = pair.target;
      for (int r = 0; r < others.rows(); r += beam_step)
        for (int c = 0; c < others.columns(); ++c) others.at(r, c) = 0.0f;
      const auto to_world = [&](const std::vector<geometry::Vec3f>& sensor) {
        std::vector<geometry::Vec3f> w;
        w.reserve(sensor.size());
        for (const auto& p : sensor) w.push_back((s.pose * p.cast<double>()).cast<float>());
        return w;
      };
      auto h = eval::splitScan(to_world(densify::toPoints(others)), s.origin(), ho, rng);
      for (const auto& t : h.tests) {
        test_points.push_back(t.p);
        labels.push_back(t.occupied);
      }
      const auto t0 = Clock::now();
      const densify::RangeImage input =
          upsampler ? upsampler->upsample(pair.input, pair.target.geometry) : pair.input;
      densify_ms += secondsSince(t0) * 1000.0;
      split.push_back({to_world(densify::toPoints(input)), s.origin()});
    }
    if (beam_step >= 2)
      spdlog::info("sparse protocol: every {}th beam, densify {} ({:.1f} ms/scan), {} test points", beam_step,
                   densify_method, densify_ms / static_cast<double>(std::max<std::size_t>(1, split.size())),
                   test_points.size());
    // One method on a share of each scan's map points (the equal-time mode lowers it in 5% steps).
    auto run = [&](const std::string& m, double usage) {
      MethodResult r;
      r.method = m;
      r.usage = usage;
      r.scans = split.size();
      std::vector<SplitScan> used = split;
      if (usage < 1.0) {
        std::mt19937_64 sub(seed + 7);
        for (auto& s : used) {
          std::shuffle(s.map_points.begin(), s.map_points.end(), sub);
          s.map_points.resize(static_cast<std::size_t>(usage * static_cast<double>(s.map_points.size())));
        }
      }
      std::vector<std::optional<float>> pred(test_points.size());
      if (m == "exact") {
        const auto grid = map::makeMap(map_options);
        update::UpdateEngine engine(update_options);
        const auto t0 = Clock::now();
        for (const auto& s : used) engine.insert(*grid, s.map_points, s.origin);
        r.seconds = secondsSince(t0);
        for (std::size_t i = 0; i < test_points.size(); ++i) {
          geometry::VoxelKey k;
          if (!grid->converter().toKey(test_points[i], k)) continue;
          if (const auto v = grid->logOdds(k)) pred[i] = map::OccupancyParams::probability(*v);
        }
      } else if (m == "bgk" || m == "akimap") {
        dense::DenseLayerOptions lo = kernel_options;
        lo.method = m;
        lo.resolution = resolution;
        lo.max_range = max_range;
        lo.seed = seed;
        const std::unique_ptr<dense::KernelLayer> layer = dense::makeDenseLayer(lo, resolution);
        const auto t0 = Clock::now();
        for (const auto& s : used) layer->insert(s.map_points, s.origin);
        r.seconds = secondsSince(t0);
        for (std::size_t i = 0; i < test_points.size(); ++i) pred[i] = layer->probability(test_points[i]);
      } else {
        throw std::invalid_argument("unknown method '" + m + "' (use exact, bgk, akimap)");
      }
      r.scores = eval::score(pred, labels);
      r.predictions = std::move(pred);
      return r;
    };
    std::vector<MethodResult> results;
    std::stringstream methods_in(methods_text);
    for (std::string m; std::getline(methods_in, m, ',');) results.push_back(run(m, 1.0));
    if (equal_time) {
      // Table 3.2's top rows: the budget is the fastest kernel method's time on all the data; slower
      // methods drop 5% of the data at a time until they fit in it.
      double budget = INFINITY;
      for (const auto& r : results) {
        if (r.method != "exact") budget = std::min(budget, r.seconds);
      }
      const std::size_t full = results.size();
      for (std::size_t i = 0; i < full; ++i) {
        if (results[i].method == "exact" || results[i].seconds <= budget) continue;
        MethodResult r = results[i];
        for (double usage = 0.95; usage > 0.04 && r.seconds > budget; usage -= 0.05) r = run(r.method, usage);
        results.push_back(r);
      }
      if (!as_json)
        std::printf("equal-time budget: %.3f s (the fastest kernel method on all the data)\n", budget);
    }
    std::ofstream csv;
    if (!roc_csv.empty()) {
      csv.open(roc_csv);
      if (!csv) throw std::runtime_error("cannot write " + roc_csv);
      csv << "method,usage,threshold,fpr,tpr\n";
    }
    if (!as_json) {
      std::printf("%s, scans %zu-%zu, %.2f m, %zu test points (%zu occupied)\n", src->describe().c_str(),
                  range.first, range.last, resolution, labels.size(),
                  results.empty() ? 0 : results[0].scores.occupied);
      std::printf("%-14s %7s %7s %9s %9s %9s %10s %11s\n", "method (data)", "AUC", "MSE", "acc_occ",
                  "acc_free", "coverage", "seconds", "ms/scan");
    }
    for (const auto& r : results) {
      const auto& s = r.scores;
      const double ms = 1000.0 * r.seconds / static_cast<double>(std::max<std::size_t>(1, r.scans));
      if (as_json) {
        nlohmann::json j = {{"method", r.method},
                            {"auc", s.auc},
                            {"mse", s.mse},
                            {"acc_occupied", s.acc_occupied},
                            {"acc_free", s.acc_free},
                            {"coverage", s.coverage},
                            {"seconds_total", r.seconds},
                            {"ms_per_scan", ms},
                            {"usage", r.usage},
                            {"scans", r.scans},
                            {"resolution", resolution},
                            {"test_points", labels.size()}};
        std::printf("%s\n", j.dump().c_str());
      } else {
        const std::string label =
            r.method + " (" + std::to_string(static_cast<int>(r.usage * 100 + 0.5)) + "%)";
        std::printf("%-14s %7.3f %7.3f %9.3f %9.3f %9.3f %10.3f %11.1f\n", label.c_str(), s.auc, s.mse,
                    s.acc_occupied, s.acc_free, s.coverage, r.seconds, ms);
      }
      if (csv) {
        for (const auto& p : s.roc) {
          csv << r.method << "," << r.usage << "," << p.threshold << "," << p.fpr << "," << p.tpr << "\n";
        }
      }
    }
    if (!predictions_csv.empty()) {
      // One row per test point, one column per method run on all the data: to see where methods differ.
      std::ofstream out(predictions_csv);
      if (!out) throw std::runtime_error("cannot write " + predictions_csv);
      out << "x,y,z,occupied";
      for (const auto& r : results)
        if (r.usage == 1.0) out << "," << r.method;
      out << "\n";
      for (std::size_t i = 0; i < test_points.size(); ++i) {
        const auto& p = test_points[i];
        out << p.x() << "," << p.y() << "," << p.z() << "," << (labels[i] ? 1 : 0);
        for (const auto& r : results) {
          if (r.usage != 1.0) continue;
          out << ",";
          if (r.predictions[i]) out << *r.predictions[i];
        }
        out << "\n";
      }
    }
    if (!roc_png.empty()) {
      // ROC plot: false-positive rate to the right, true-positive rate up; the chance diagonal in grey.
      constexpr int kSize = 480, kMargin = 32;
      util::Image img(kSize + 2 * kMargin, kSize + 2 * kMargin);
      const std::uint8_t black[3] = {0, 0, 0}, grey[3] = {190, 190, 190};
      auto px = [&](double fpr) { return kMargin + static_cast<int>(fpr * kSize); };
      auto py = [&](double tpr) { return kMargin + kSize - static_cast<int>(tpr * kSize); };
      img.line(px(0), py(0), px(1), py(1), grey);
      img.line(px(0), py(0), px(1), py(0), black);
      img.line(px(0), py(0), px(0), py(1), black);
      for (const auto& r : results) {
        std::uint8_t c[3] = {40, 70, 200};  // exact: blue
        if (r.method == "bgk") c[0] = 30, c[1] = 160, c[2] = 60;
        if (r.method == "akimap") c[0] = 210, c[1] = 40, c[2] = 40;
        const int thickness = r.usage < 1.0 ? 1 : 3;  // equal-time runs drawn thin
        for (std::size_t k = 1; k < r.scores.roc.size(); ++k) {
          const auto& a = r.scores.roc[k - 1];
          const auto& b = r.scores.roc[k];
          img.line(px(a.fpr), py(a.tpr), px(b.fpr), py(b.tpr), c, thickness);
        }
      }
      util::writePng(roc_png, img);
      if (!as_json)
        std::printf("ROC curves: %s (exact blue, bgk green, akimap red; thin: equal-time runs)\n",
                    roc_png.c_str());
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
