// densemap-iln: train, evaluate and apply the Implicit LiDAR Network (Ch. 4) on the CPU.
//   densemap-iln train --kitti ../shared/data/kitti00 --steps 3000 --out models/iln/iln_compact.pt
//   densemap-iln eval --source ../shared/data/kitti00 --scans 50:59 --json
//   densemap-iln upsample --in scan16.pcd --out scan64.pcd --rows 64 --columns 1024
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/cli/common_options.h"
#include "densemap/cli/option_cli.h"
#include "densemap/densify/densify_dataset.h"
#include "densemap/densify/error_breakdown.h"
#include "densemap/densify/iln_upsampler.h"
#include "densemap/densify/model_files.h"
#include "densemap/io/pcd_file.h"
#include "densemap/sources/open_source.h"

using namespace densemap;
using densify::LidarGeometry;
using Clock = std::chrono::steady_clock;

namespace {

double seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

LidarGeometry geometryOf(const io::Scan& scan, int rows, int columns) {
  LidarGeometry g = scan.lidar.value_or(LidarGeometry{});
  if (rows > 0) g.rows = rows;
  if (columns > 0) g.columns = columns;
  return g;
}

struct TrainArgs {
  std::string model = "compact", out, checkpoint, init, kitti, kitti_scans = "0:49", sim_style = "both";
  int steps = 2000, sim_scenes = 8, sim_scans = 12, threads = 2, log_every = 50, checkpoint_every = 250;
  int target_rows = 64, target_columns = 1024, beam_step = 4;
  std::vector<std::string> extra_targets;  // "RxC": more clean-render target sizes
  std::uint64_t seed = 1;
  densify::IlnTrainOptions train;
};

int runTrain(const TrainArgs& a) {
  densify::IlnUpsampler::setThreads(a.threads);
  const LidarGeometry dense{a.target_rows, a.target_columns, 2.0, -24.9, 360.0};
  const LidarGeometry input_base{64, 1024, 2.0, -24.9, 360.0};
  // More target sizes teach the model queries that fall between input columns (at 64x1024 from 16x1024
  // every query shares its column with the input), which a resolution-free model needs (Sec. 4.3).
  std::vector<LidarGeometry> extra;
  for (const std::string& size : a.extra_targets) {
    int rows = 0, columns = 0;
    char x = 0;
    std::istringstream in(size);
    if (!(in >> rows >> x >> columns) || x != 'x' || rows <= 0 || columns <= 0 || !in.eof())
      throw std::invalid_argument("--extra-targets: '" + size + "' is not ROWSxCOLUMNS (e.g. 128x2048)");
    extra.push_back(
        LidarGeometry{rows, columns, dense.fov_up_deg, dense.fov_down_deg, dense.fov_horizontal_deg});
  }
  // --sim-style: a comma list of clean, sensor and real sensor models (both = clean,sensor).
  std::vector<std::string> styles;
  std::vector<io::SpinningLidarModel> models;
  {
    std::stringstream list(a.sim_style);
    for (std::string style; std::getline(list, style, ',');) {
      if (style == "both") {
        styles.insert(styles.end(), {"clean", "sensor"});
      } else if (style == "clean" || style == "sensor") {
        styles.push_back(style);
      } else {
        models.push_back(io::SpinningLidarModel::byName(style));  // throws naming the known ones
      }
    }
  }
  const auto has = [](const std::vector<std::string>& v, const char* x) {
    return std::find(v.begin(), v.end(), x) != v.end();
  };
  std::vector<densify::RangeImagePair> data;
  const auto t_data = Clock::now();
  {
    cli::Progress progress("simulator scenes", static_cast<std::size_t>(a.sim_scenes));
    for (int s = 0; s < a.sim_scenes; ++s) {
      // Scene seeds 1000+ train; densemap-iln eval's simulator test scenes use seeds below 1000.
      const auto seed = 1000 + static_cast<std::uint64_t>(s);
      if (has(styles, "clean")) {
        auto ex = densify::simulatorExamples(seed, a.sim_scans, input_base, a.beam_step, dense);
        std::move(ex.begin(), ex.end(), std::back_inserter(data));
      }
      for (const LidarGeometry& target : extra) {
        auto ex = densify::simulatorExamples(seed, a.sim_scans, input_base, a.beam_step, target);
        std::move(ex.begin(), ex.end(), std::back_inserter(data));
      }
      if (has(styles, "sensor") && dense.rows == input_base.rows) {
        auto ex = densify::sensorLikeSimulatorExamples(seed + 500, a.sim_scans, dense, a.beam_step);
        std::move(ex.begin(), ex.end(), std::back_inserter(data));
      }
      for (const io::SpinningLidarModel& model : models) {
        auto ex = densify::sensorModelSimulatorExamples(
            seed + 2000, a.sim_scans, model, densify::imageGridOf(model, a.target_columns), a.beam_step);
        std::move(ex.begin(), ex.end(), std::back_inserter(data));
      }
      progress.step(static_cast<std::size_t>(s + 1));
    }
  }
  if (!a.kitti.empty()) {
    auto src = sources::openSource(a.kitti);
    const auto range = cli::parseScanRange(a.kitti_scans, src->size());
    if (range.last >= 50 && a.kitti.find("kitti00") != std::string::npos)
      spdlog::warn("training on kitti00 scans >= 50, which densemap-iln eval holds out");
    for (std::size_t i = range.first; i <= range.last; ++i) {
      const io::Scan scan = src->read(i);
      data.push_back(densify::exampleFromScan(scan, geometryOf(scan, 64, 1024), a.beam_step));
    }
  }
  spdlog::info("training data: {} pairs ({:.1f} s to prepare)", data.size(), seconds(t_data));

  const bool resume = !a.checkpoint.empty() && std::filesystem::exists(a.checkpoint);
  densify::IlnUpsampler net =
      resume ? densify::IlnUpsampler::load(a.checkpoint)
      : !a.init.empty()
          ? densify::IlnUpsampler::load(a.init)
          : densify::IlnUpsampler(
                a.model == "full" ? densify::IlnOptions::full() : densify::IlnOptions::compact(), a.seed);
  if (resume) {
    spdlog::info("resuming {} at step {}", a.checkpoint, net.step());
  } else if (!a.init.empty()) {
    net.restartTraining();  // fine-tuning: these weights, a fresh optimiser, step 0
    spdlog::info("fine-tuning from {}", a.init);
  }
  spdlog::info("model: {} blocks, {} channels, {} heads, MLP {}: {} parameters", net.options().blocks,
               net.options().channels, net.options().heads, net.options().mlp, net.parameterCount());
  std::mt19937 rng(static_cast<unsigned>(a.seed + net.step()));
  const auto t0 = Clock::now();
  double loss_sum = 0;
  int loss_n = 0;
  const std::uint64_t start = net.step();
  while (net.step() < static_cast<std::uint64_t>(a.steps)) {
    loss_sum += net.trainStep(data, a.train, rng);
    ++loss_n;
    const std::uint64_t done = net.step() - start;
    if (net.step() % static_cast<std::uint64_t>(a.log_every) == 0) {
      const double per_step = seconds(t0) / static_cast<double>(done);
      spdlog::info("step {}/{}: L1 {:.3f} m, {:.2f} s/step, {:.0f} s to go", net.step(), a.steps,
                   loss_sum / loss_n, per_step,
                   per_step * static_cast<double>(a.steps - static_cast<int>(net.step())));
      loss_sum = 0;
      loss_n = 0;
    }
    if (!a.checkpoint.empty() && net.step() % static_cast<std::uint64_t>(a.checkpoint_every) == 0)
      net.save(a.checkpoint, true);
  }
  if (!a.checkpoint.empty()) net.save(a.checkpoint, true);
  net.save(a.out, false);
  std::printf("trained %llu steps in %.0f s (this run); weights: %s (%zu parameters)\n",
              static_cast<unsigned long long>(net.step() - start), seconds(t0), a.out.c_str(),
              net.parameterCount());
  return 0;
}

struct EvalArgs {
  std::string source, scans, methods = "iln,bilinear,nearest", weights, full_weights;
  int rows = 64, columns = 1024, beam_step = 4, threads = 2, sim_scenes = 2, sim_scans = 5;
  bool json = false, breakdown = false;
};

int runEval(const EvalArgs& a) {
  densify::IlnUpsampler::setThreads(a.threads);
  std::vector<std::pair<densify::RangeImagePair, std::vector<densify::Vec3f>>> pairs;
  std::string described;
  if (a.source.empty() || a.source == "sim") {
    // Simulator test scenes (seeds 1..n, never trained on: training uses 1000+).
    const LidarGeometry dense{a.rows, a.columns, 2.0, -24.9, 360.0};
    const LidarGeometry base{64, 1024, 2.0, -24.9, 360.0};
    for (int s = 0; s < a.sim_scenes; ++s)
      for (auto& ex : densify::simulatorExamples(1 + static_cast<std::uint64_t>(s), a.sim_scans, base,
                                                 a.beam_step, dense)) {
        auto pts = densify::toPoints(ex.target);
        pairs.emplace_back(std::move(ex), std::move(pts));
      }
    described = "simulator test scenes (seeds 1.." + std::to_string(a.sim_scenes) + ")";
  } else if (a.source.rfind("sim:", 0) == 0) {
    // A real sensor's model in the simulator (test scenes: seeds below 1000, as above).
    const io::SpinningLidarModel model = io::SpinningLidarModel::byName(a.source.substr(4));
    for (int s = 0; s < a.sim_scenes; ++s)
      for (auto& ex :
           densify::sensorModelSimulatorExamples(1 + static_cast<std::uint64_t>(s), a.sim_scans, model,
                                                 densify::imageGridOf(model, a.columns), a.beam_step)) {
        auto pts = densify::toPoints(ex.target);
        pairs.emplace_back(std::move(ex), std::move(pts));
      }
    described =
        model.name + " model in simulator test scenes (seeds 1.." + std::to_string(a.sim_scenes) + ")";
  } else {
    auto src = sources::openSource(a.source);
    const auto range = cli::parseScanRange(a.scans, src->size());
    described = src->describe();
    for (std::size_t i = range.first; i <= range.last; ++i) {
      const io::Scan scan = src->read(i);
      pairs.emplace_back(densify::exampleFromScan(scan, geometryOf(scan, a.rows, a.columns), a.beam_step),
                         scan.sensorPoints());
    }
  }
  // With --json stdout carries only the JSON lines (logs go to stdout here), so this one goes to stderr.
  if (a.json)
    std::fprintf(stderr, "evaluating %zu scans of %s\n", pairs.size(), described.c_str());
  else
    spdlog::info("evaluating {} scans of {}", pairs.size(), described);

  std::vector<std::unique_ptr<densify::RangeUpsampler>> methods;
  std::stringstream list(a.methods);
  for (std::string m; std::getline(list, m, ',');) {
    if (m == "bilinear") {
      methods.push_back(std::make_unique<densify::BilinearUpsampler>());
    } else if (m == "nearest") {
      methods.push_back(std::make_unique<densify::NearestUpsampler>());
    } else if (m.rfind("iln:", 0) == 0) {
      // iln:PATH — any weights file, named after it (e.g. iln:out/iln_kitti.pt -> iln-iln_kitti).
      auto net = std::make_unique<densify::IlnUpsampler>(densify::IlnUpsampler::load(m.substr(4)));
      net->setName("iln-" + std::filesystem::path(m.substr(4)).stem().string());
      methods.push_back(std::move(net));
    } else if (m == "iln" || m == "iln-compact" || m == "iln-full") {
      const std::string w =
          m == "iln-full" ? (a.full_weights.empty() ? densify::shippedWeights("iln_full.pt") : a.full_weights)
                          : (a.weights.empty() ? densify::shippedWeights("iln_compact.pt") : a.weights);
      auto net = std::make_unique<densify::IlnUpsampler>(densify::IlnUpsampler::load(w));
      net->setName(m);
      methods.push_back(std::move(net));
    } else {
      throw std::invalid_argument("unknown method '" + m +
                                  "' (use iln, iln-compact, iln-full, bilinear, nearest)");
    }
  }
  for (auto& method : methods) {
    densify::ReconstructionScore sum;
    double ms = 0;
    std::vector<double> times;
    densify::ErrorBreakdownOptions bo;
    bo.beam_step = a.beam_step;
    densify::ErrorBreakdown breakdown(bo);
    for (const auto& [pair, points] : pairs) {
      const auto t0 = Clock::now();
      const auto predicted = method->upsample(pair.input, pair.target.geometry);
      times.push_back(seconds(t0) * 1000.0);
      ms += times.back();
      const auto s = densify::scoreReconstruction(predicted, pair.target, points);
      if (a.breakdown) breakdown.add(pair.input, predicted, pair.target);
      sum.mae_m += s.mae_m;
      sum.iou += s.iou;
      sum.precision += s.precision;
      sum.recall += s.recall;
      sum.f1 += s.f1;
    }
    const double n = static_cast<double>(std::max<std::size_t>(1, pairs.size()));
    // The median resists this noisy 2-core machine's outliers (and the first call's warm-up).
    std::sort(times.begin(), times.end());
    const double median = times.empty() ? 0.0 : times[times.size() / 2];
    nlohmann::json j = {
        {"method", method->name()},     {"source", described}, {"scans", pairs.size()},
        {"mae_m", sum.mae_m / n},       {"iou", sum.iou / n},  {"precision", sum.precision / n},
        {"recall", sum.recall / n},     {"f1", sum.f1 / n},    {"ms_per_scan", ms / n},
        {"ms_per_scan_median", median}, {"threads", a.threads}};
    if (a.breakdown)
      for (const densify::ErrorBin& bin : breakdown.bins())
        j["mae_by"][bin.name] = {{"mae_m", bin.mae()}, {"pixels", bin.pixels}};
    if (a.json) {
      std::printf("%s\n", j.dump().c_str());
    } else {
      std::printf(
          "%-12s MAE %.3f m  IoU %.3f  precision %.3f  recall %.3f  F1 %.3f  %.1f ms/scan (median %.1f)\n",
          method->name().c_str(), sum.mae_m / n, sum.iou / n, sum.precision / n, sum.recall / n, sum.f1 / n,
          ms / n, median);
      if (a.breakdown)
        for (const densify::ErrorBin& bin : breakdown.bins())
          std::printf("    %-26s MAE %.3f m over %zu pixels\n", bin.name.c_str(), bin.mae(), bin.pixels);
    }
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-iln: LiDAR super-resolution with the Implicit LiDAR Network (Ch. 4), on the CPU"};
  app.require_subcommand(1);
  std::string log_level = "info";
  auto logging_table = cli::loggingOptions(log_level);
  cli::addToApp(app, {&logging_table});

  TrainArgs t;
  auto* train =
      app.add_subcommand("train", "train ILN on simulator scenes (and real 64-beam scans), resumable");
  train->add_option("--model", t.model, "compact (the server's default) or full (Ch. 4's size)")
      ->capture_default_str()
      ->check(CLI::IsMember({"compact", "full"}));
  train->add_option("--out", t.out, "where to write the trained weights")->required();
  train->add_option("--checkpoint", t.checkpoint,
                    "checkpoint with the optimiser state; an existing one is resumed");
  train->add_option("--init", t.init, "start from these weights (fine-tuning; --model is then theirs)");
  train->add_option("--steps", t.steps, "total optimisation steps (a resumed run continues to this)")
      ->capture_default_str();
  train->add_option("--kitti", t.kitti, "a 64-beam scan source to add (e.g. ../shared/data/kitti00)");
  train->add_option("--kitti-scans", t.kitti_scans, "its scans FIRST:LAST")->capture_default_str();
  train->add_option("--sim-scenes", t.sim_scenes, "procedural scenes rendered for training")
      ->capture_default_str();
  train->add_option("--sim-scans", t.sim_scans, "poses per scene")->capture_default_str();
  train
      ->add_option(
          "--sim-style", t.sim_style,
          "comma list: clean (renders on the pixel grid), sensor (a uniform sensor projected like "
          "real scans: offset beams, 2048 returns per beam, 2 cm noise), both (= clean,sensor), or a "
          "real sensor's model: hdl64e, vlp16, os1_64 (its beam table, a unit's offsets and tilt, "
          "noise, lost returns, foliage; scenes with pavements and hedges)")
      ->capture_default_str();
  train->add_option("--target-rows", t.target_rows, "target beams (64; 128 with --target-columns 2048)")
      ->capture_default_str();
  train->add_option("--target-columns", t.target_columns, "target columns")->capture_default_str();
  train
      ->add_option("--extra-targets", t.extra_targets,
                   "more target sizes ROWSxCOLUMNS for the simulator scenes (clean renders), e.g. 128x2048")
      ->delimiter(',');
  train->add_option("--beam-step", t.beam_step, "input keeps every n-th beam (4: 64 -> 16)")
      ->capture_default_str();
  train->add_option("--batch", t.train.batch, "crops per step")->capture_default_str();
  train->add_option("--crop-columns", t.train.crop_columns, "input columns per crop")->capture_default_str();
  train->add_option("--queries", t.train.queries_per_example, "target pixels per crop")
      ->capture_default_str();
  train->add_option("--lr", t.train.learning_rate, "Adam learning rate")->capture_default_str();
  train->add_option("--seed", t.seed, "initialisation and sampling seed")->capture_default_str();
  train->add_option("--threads", t.threads, "libtorch threads")->capture_default_str();
  train->add_option("--log-every", t.log_every, "steps between progress lines")->capture_default_str();
  train->add_option("--checkpoint-every", t.checkpoint_every, "steps between checkpoints")
      ->capture_default_str();

  EvalArgs e;
  auto* eval =
      app.add_subcommand("eval", "MAE, IoU, precision, recall, F1 (0.1 m voxels) and time per method");
  eval->add_option("--source", e.source,
                   "64-beam scans (sequence directory, KITTI layout...), 'sim' (default: clean renders) or "
                   "'sim:MODEL' (a real sensor's model: hdl64e, vlp16, os1_64)");
  eval->add_option("--scans", e.scans, "scan range FIRST:LAST");
  eval->add_option("--methods", e.methods,
                   "comma list of iln, iln-compact, iln-full, iln:WEIGHTS, bilinear, nearest")
      ->capture_default_str();
  eval->add_option("--weights", e.weights,
                   "weights for iln / iln-compact (default models/iln/iln_compact.pt)");
  eval->add_option("--full-weights", e.full_weights, "weights for iln-full (default models/iln/iln_full.pt)");
  eval->add_option("--rows", e.rows, "output beams")->capture_default_str();
  eval->add_option("--columns", e.columns, "output columns")->capture_default_str();
  eval->add_option("--beam-step", e.beam_step, "input keeps every n-th beam")->capture_default_str();
  eval->add_option("--sim-scenes", e.sim_scenes, "with --source sim: test scenes")->capture_default_str();
  eval->add_option("--sim-scans", e.sim_scans, "with --source sim: poses per scene")->capture_default_str();
  eval->add_option("--threads", e.threads, "libtorch threads")->capture_default_str();
  eval->add_flag("--json", e.json, "one JSON object per method");
  eval->add_flag("--breakdown", e.breakdown,
                 "also the MAE by row (on / between / below the input beams), range, depth edge, ground and "
                 "the top and bottom rows");

  std::string in, out, weights;
  int rows = 64, columns = 1024, in_rows = 16, threads = 2;
  auto* up = app.add_subcommand("upsample", "densify a sensor-frame PCD scan with ILN (file in, file out)");
  up->add_option("--in", in, "sparse scan, sensor frame (PCD)")->required()->check(CLI::ExistingFile);
  up->add_option("--out", out, "dense scan to write (PCD)")->required();
  up->add_option("--input-rows", in_rows,
                 "beams of the input (its field of view is the KITTI one, 2 to -24.9 deg)")
      ->capture_default_str();
  up->add_option("--rows", rows, "output beams")->capture_default_str();
  up->add_option("--columns", columns, "output columns")->capture_default_str();
  up->add_option("--weights", weights, "ILN weights (default models/iln/iln_compact.pt)");
  up->add_option("--threads", threads, "libtorch threads")->capture_default_str();

  if (const auto rc = cli::parse(app, argc, argv, {&logging_table})) return *rc;
  cli::setupLogging(log_level);
  try {
    if (*train) return runTrain(t);
    if (*eval) return runEval(e);
    densify::IlnUpsampler::setThreads(threads);
    auto net =
        densify::IlnUpsampler::load(weights.empty() ? densify::shippedWeights("iln_compact.pt") : weights);
    const LidarGeometry kitti{};
    const LidarGeometry sparse =
        densify::everyNthBeam(kitti, std::max(1, (kitti.rows - 1) / std::max(1, in_rows - 1)));
    const auto pcd = io::readPcd(in);
    const auto image = densify::project(
        pcd.points, LidarGeometry{in_rows, columns, sparse.fov_up_deg, sparse.fov_down_deg, 360.0});
    const auto t0 = Clock::now();
    const auto dense =
        net.upsample(image, LidarGeometry{rows, columns, kitti.fov_up_deg, kitti.fov_down_deg, 360.0});
    const auto pts = densify::toPoints(dense);
    io::writePcd(out, pts);
    std::printf("%s: %zu points in, %zu out (%d x %d) in %.1f ms\n", out.c_str(), pcd.points.size(),
                pts.size(), rows, columns, seconds(t0) * 1000.0);
  } catch (const std::exception& ex) {
    spdlog::error("{}", ex.what());
    return 1;
  }
  return 0;
}
