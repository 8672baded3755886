// The only translation unit that includes <torch/torch.h> (each costs ~20 s to compile).
#include "densemap/densify/iln_upsampler.h"

#include "densemap/densify/iln_weight_head.h"

#include <torch/torch.h>

#include <dlfcn.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <spdlog/spdlog.h>

namespace densemap::densify {

namespace {

namespace F = torch::nn::functional;

/// 3x3 convolution padded by replicating rows (no data above the top beam or below the bottom one) and
/// wrapping columns (the sweep is 360 degrees), as Ch. 4's encoder needs for range images.
struct RangeConvImpl : torch::nn::Module {
  RangeConvImpl(int in, int out)
      : conv(register_module("conv", torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 3)))) {}
  torch::Tensor forward(const torch::Tensor& x) {
    auto y = F::pad(x, F::PadFuncOptions({1, 1, 0, 0}).mode(torch::kCircular));
    y = F::pad(y, F::PadFuncOptions({0, 0, 1, 1}).mode(torch::kReplicate));
    return conv->forward(y);
  }
  torch::nn::Conv2d conv;
};
TORCH_MODULE(RangeConv);

/// EDSR residual block: conv-ReLU-conv plus the input, no batch norm.
struct ResidualBlockImpl : torch::nn::Module {
  explicit ResidualBlockImpl(int c)
      : a(register_module("a", RangeConv(c, c))), b(register_module("b", RangeConv(c, c))) {}
  torch::Tensor forward(const torch::Tensor& x) { return x + b->forward(torch::relu(a->forward(x))); }
  RangeConv a, b;
};
TORCH_MODULE(ResidualBlock);

/// EDSR-baseline encoder (Sec. 4.3.1): head conv, residual blocks, tail conv and a long skip.
struct EncoderImpl : torch::nn::Module {
  EncoderImpl(int blocks, int c)
      : head(register_module("head", RangeConv(1, c))), tail(register_module("tail", RangeConv(c, c))) {
    for (int i = 0; i < blocks; ++i) body->push_back(ResidualBlock(c));
    register_module("body", body);
  }
  torch::Tensor forward(const torch::Tensor& x) {
    const auto h = head->forward(x);
    return h + tail->forward(body->forward(h));
  }
  RangeConv head, tail;
  torch::nn::Sequential body;
};
TORCH_MODULE(Encoder);

/// The weight predictor for one query's 4 tokens (Secs. 4.3.1-4.3.3): offset embedding, one pre-norm
/// self-attention block, LayerNorm and a shared linear layer giving one score per neighbour.
struct WeightHeadImpl : torch::nn::Module {
  WeightHeadImpl(int c, int heads, int mlp)
      : heads(heads),
        embed(register_module("embed", torch::nn::Linear(2, c))),
        norm1(register_module("norm1", torch::nn::LayerNorm(torch::nn::LayerNormOptions({c})))),
        qkv(register_module("qkv", torch::nn::Linear(c, 3 * c))),
        proj(register_module("proj", torch::nn::Linear(c, c))),
        norm2(register_module("norm2", torch::nn::LayerNorm(torch::nn::LayerNormOptions({c})))),
        fc1(register_module("fc1", torch::nn::Linear(c, mlp))),
        fc2(register_module("fc2", torch::nn::Linear(mlp, c))),
        norm3(register_module("norm3", torch::nn::LayerNorm(torch::nn::LayerNormOptions({c})))),
        score(register_module("score", torch::nn::Linear(c, 1))) {}

  /// tokens [N, 4, C] (neighbour features), offsets [N, 4, 2] -> scores [N, 4]
  torch::Tensor forward(const torch::Tensor& tokens, const torch::Tensor& offsets) {
    auto x = tokens + embed->forward(offsets);
    const auto n = x.size(0), c = x.size(2);
    const auto hd = c / heads;
    auto q = qkv->forward(norm1->forward(x)).view({n, 4, 3, heads, hd}).permute({2, 0, 3, 1, 4});
    auto att =
        torch::softmax(torch::matmul(q[0], q[1].transpose(-2, -1)) / std::sqrt(static_cast<double>(hd)), -1);
    auto mixed = torch::matmul(att, q[2]).transpose(1, 2).reshape({n, 4, c});
    x = x + proj->forward(mixed);
    x = x + fc2->forward(F::gelu(fc1->forward(norm2->forward(x))));
    return score->forward(norm3->forward(x)).squeeze(-1);
  }
  int heads;
  torch::nn::Linear embed;
  torch::nn::LayerNorm norm1;
  torch::nn::Linear qkv, proj;
  torch::nn::LayerNorm norm2;
  torch::nn::Linear fc1, fc2;
  torch::nn::LayerNorm norm3;
  torch::nn::Linear score;
};
TORCH_MODULE(WeightHead);

struct IlnNetImpl : torch::nn::Module {
  explicit IlnNetImpl(const IlnOptions& o)
      : encoder(register_module("encoder", Encoder(o.blocks, o.channels))),
        head(register_module("head", WeightHead(o.channels, o.heads, o.mlp))) {}

  /// image [B, 1, H, W] normalised; index [B, Q, 4] flat pixel indices; offsets [B, Q, 4, 2];
  /// neighbour ranges [B, Q, 4] normalised; valid [B, Q, 4] -> predicted normalised range [B, Q]
  torch::Tensor forward(const torch::Tensor& image, const torch::Tensor& index, const torch::Tensor& offsets,
                        const torch::Tensor& ranges, const torch::Tensor& valid) {
    const auto feat = encoder->forward(image);  // [B, C, H, W]
    const auto b = feat.size(0), c = feat.size(1), q = index.size(1);
    const auto flat = feat.flatten(2).transpose(1, 2);  // [B, HW, C]
    const auto gathered = torch::gather(flat, 1, index.reshape({b, q * 4, 1}).expand({b, q * 4, c}));
    const auto scores = head->forward(gathered.reshape({b * q, 4, c}), offsets.reshape({b * q, 4, 2}))
                            .reshape({b, q, 4})
                            .masked_fill(valid.logical_not(), -1e9);
    // Eq. 4.3: the prediction is a convex combination of the measured neighbour ranges.
    return (torch::softmax(scores, -1) * ranges).sum(-1);
  }
  Encoder encoder;
  WeightHead head;
};
TORCH_MODULE(IlnNet);

torch::Tensor imageTensor(const RangeImage& img, float max_range) {
  auto t = torch::from_blob(const_cast<float*>(img.range.data()), {1, 1, img.rows(), img.columns()},
                            torch::kFloat32)
               .clone();
  // Missing returns read as range 0, i.e. -1 after normalisation.
  return t / max_range * 2.0 - 1.0;
}

/// The trained weight head's parameters for IlnWeightHead, inference without libtorch's per-operator
/// overhead: with 4 tokens of 16-64 values, torch spent ~10 us per query on dispatch and temporaries
/// (measured 180-760 ms for 44k queries).
IlnWeightHeadParameters headParameters(WeightHeadImpl& h) {
  const auto copy = [](const torch::Tensor& t) {
    const auto c = t.detach().contiguous().to(torch::kFloat32);
    return std::vector<float>(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  };
  IlnWeightHeadParameters p;
  p.channels = static_cast<int>(h.qkv->weight.size(1));
  p.heads = h.heads;
  p.mlp = static_cast<int>(h.fc1->weight.size(0));
  p.embed_w = copy(h.embed->weight), p.embed_b = copy(h.embed->bias);
  p.norm1_g = copy(h.norm1->weight), p.norm1_b = copy(h.norm1->bias);
  p.qkv_w = copy(h.qkv->weight), p.qkv_b = copy(h.qkv->bias);
  p.proj_w = copy(h.proj->weight), p.proj_b = copy(h.proj->bias);
  p.norm2_g = copy(h.norm2->weight), p.norm2_b = copy(h.norm2->bias);
  p.fc1_w = copy(h.fc1->weight), p.fc1_b = copy(h.fc1->bias);
  p.fc2_w = copy(h.fc2->weight), p.fc2_b = copy(h.fc2->bias);
  p.norm3_g = copy(h.norm3->weight), p.norm3_b = copy(h.norm3->bias);
  p.score_w = copy(h.score->weight), p.score_b = copy(h.score->bias);
  return p;
}

/// libtorch runs these convolutions as im2col + sgemm on the system BLAS (Debian: OpenBLAS, pthreads). Its
/// worker thread spins on sched_yield for about 0.1 s after each call and so takes a core from the OpenMP
/// threads doing the rest: encoder stalls of 85-130 ms in 1-3 scans of 20, training 40% slower (measured,
/// docs/BENCHMARKS.md). With one BLAS thread both go; libtorch and the weight head still use OpenMP.
void keepBlasOnTheCallingThread() {
  void* blas = dlopen("libopenblas.so.0", RTLD_LAZY | RTLD_NOLOAD);
  if (!blas) return;  // another BLAS, not loaded by libtorch here
  using SetThreads = void (*)(int);
  if (auto* set = reinterpret_cast<SetThreads>(dlsym(blas, "openblas_set_num_threads"))) set(1);
  dlclose(blas);
}

}  // namespace

struct IlnUpsampler::Impl {
  explicit Impl(const IlnOptions& o) : options(o), net(o) {}
  IlnOptions options;
  IlnNet net;
  std::unique_ptr<torch::optim::Adam> adam;
  std::uint64_t step = 0;
  std::unique_ptr<IlnWeightHead> fast;  ///< rebuilt when the weights change (training steps, loading)
  std::uint64_t fast_step = ~0ull;

  // The query geometry of the last layout pair (a server densifies one LiDAR's scans to one layout).
  LidarGeometry neighbours_in{}, neighbours_out{};
  std::vector<QueryNeighbours> neighbour_cache;
  const std::vector<QueryNeighbours>& neighbours(const LidarGeometry& in, const LidarGeometry& out) {
    const auto same = [](const LidarGeometry& a, const LidarGeometry& b) {
      return a.rows == b.rows && a.columns == b.columns && a.fov_up_deg == b.fov_up_deg &&
             a.fov_down_deg == b.fov_down_deg && a.fov_horizontal_deg == b.fov_horizontal_deg;
    };
    if (neighbour_cache.empty() || !same(in, neighbours_in) || !same(out, neighbours_out)) {
      neighbour_cache = queryNeighbours(in, out);
      neighbours_in = in;
      neighbours_out = out;
    }
    return neighbour_cache;
  }

  const IlnWeightHead& fastHead() {
    if (!fast || fast_step != step) {
      fast = std::make_unique<IlnWeightHead>(headParameters(*net->head));
      fast_step = step;
    }
    return *fast;
  }

  torch::optim::Adam& optimizer(double lr) {
    if (!adam) adam = std::make_unique<torch::optim::Adam>(net->parameters(), torch::optim::AdamOptions(lr));
    for (auto& group : adam->param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
    return *adam;
  }
};

IlnUpsampler::IlnUpsampler(const IlnOptions& options, std::uint64_t seed) {
  if (options.blocks < 0 || options.channels < 1 || options.heads < 1 ||
      options.channels % options.heads != 0 || options.mlp < 1 || !(options.max_range > 0))
    throw std::invalid_argument("ILN options: channels must be a positive multiple of heads, blocks >= 0");
  torch::manual_seed(seed);
  impl_ = std::make_unique<Impl>(options);
  static const bool process_tuned = [] {
    // Each scan allocates and frees the same few-MB tensors; glibc would hand them back to the kernel and
    // fault them in again (a sixth of inference time in a profile). Keep freed memory for reuse instead.
    mallopt(M_MMAP_THRESHOLD, 64 << 20);
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    keepBlasOnTheCallingThread();
    return true;
  }();
  (void)process_tuned;
}
IlnUpsampler::~IlnUpsampler() = default;
IlnUpsampler::IlnUpsampler(IlnUpsampler&&) noexcept = default;
IlnUpsampler& IlnUpsampler::operator=(IlnUpsampler&&) noexcept = default;

const IlnOptions& IlnUpsampler::options() const { return impl_->options; }
std::uint64_t IlnUpsampler::step() const { return impl_->step; }
void IlnUpsampler::restartTraining() {
  impl_->adam.reset();
  impl_->step = 0;
  impl_->fast.reset();
}
void IlnUpsampler::setThreads(int threads) { at::set_num_threads(std::max(1, threads)); }

std::size_t IlnUpsampler::parameterCount() const {
  std::size_t n = 0;
  for (const auto& p : impl_->net->parameters()) n += static_cast<std::size_t>(p.numel());
  return n;
}

void IlnUpsampler::save(const std::string& path, bool with_optimizer) const {
  try {
    torch::serialize::OutputArchive root;
    const IlnOptions& o = impl_->options;
    root.write("densemap_iln_format", torch::tensor(std::vector<std::int64_t>{1}));
    root.write("options", torch::tensor(std::vector<std::int64_t>{o.blocks, o.channels, o.heads, o.mlp}));
    root.write("max_range", torch::tensor(std::vector<float>{o.max_range}));
    root.write("step", torch::tensor(std::vector<std::int64_t>{static_cast<std::int64_t>(impl_->step)}));
    torch::serialize::OutputArchive model;
    impl_->net->save(model);
    root.write("model", model);
    if (with_optimizer && impl_->adam) {
      torch::serialize::OutputArchive opt;
      impl_->adam->save(opt);
      root.write("optimizer", opt);
    }
    root.save_to(path);
  } catch (const c10::Error& e) {
    throw std::runtime_error("cannot write ILN weights to " + path + ": " + e.what_without_backtrace());
  }
}

IlnUpsampler IlnUpsampler::load(const std::string& path) {
  try {
    torch::serialize::InputArchive root;
    root.load_from(path);
    torch::Tensor format, opts, max_range, step;
    if (!root.try_read("densemap_iln_format", format) || !root.try_read("options", opts) ||
        !root.try_read("max_range", max_range))
      throw std::runtime_error(
          path + " is not a densemap ILN checkpoint (no options); train one with densemap-iln train");
    const auto v = opts.to(torch::kInt64);
    IlnOptions o{static_cast<int>(v[0].item<std::int64_t>()), static_cast<int>(v[1].item<std::int64_t>()),
                 static_cast<int>(v[2].item<std::int64_t>()), static_cast<int>(v[3].item<std::int64_t>()),
                 max_range[0].item<float>()};
    IlnUpsampler up(o);
    torch::serialize::InputArchive model;
    root.read("model", model);
    up.impl_->net->load(model);
    if (root.try_read("step", step))
      up.impl_->step = static_cast<std::uint64_t>(step[0].item<std::int64_t>());
    torch::serialize::InputArchive opt;
    if (root.try_read("optimizer", opt)) up.impl_->optimizer(1e-4).load(opt);
    return up;
  } catch (const c10::Error& e) {
    throw std::runtime_error("cannot read ILN weights from " + path +
                             " (missing or corrupt): " + e.what_without_backtrace());
  }
}

RangeImage IlnUpsampler::upsample(const RangeImage& input, const LidarGeometry& output) {
  torch::NoGradGuard no_grad;
  impl_->net->eval();
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  const auto t0 = Clock::now();
  const float mr = impl_->options.max_range;
  const auto& queries = impl_->neighbours(input.geometry, output);
  RangeImage out(output);
  // Pixels on a measured input pixel keep it; only the others go through the network.
  std::vector<std::int64_t> todo;
  std::vector<std::int64_t> index;
  std::vector<float> offsets, ranges;
  std::vector<std::uint8_t> valid;
  for (std::size_t k = 0; k < queries.size(); ++k) {
    const QueryNeighbours& q = queries[k];
    bool any = false;
    for (std::size_t t = 0; t < 4; ++t) any = any || input.range[static_cast<std::size_t>(q.index[t])] > 0.0f;
    if (!any) continue;
    bool on_pixel = false;
    for (std::size_t t = 0; t < 4 && !on_pixel; ++t) {
      if (std::abs(q.offset[t][0]) < 1e-4f && std::abs(q.offset[t][1]) < 1e-4f) {
        out.range[k] = input.range[static_cast<std::size_t>(q.index[t])];
        on_pixel = true;
      }
    }
    if (on_pixel) continue;
    todo.push_back(static_cast<std::int64_t>(k));
    for (std::size_t t = 0; t < 4; ++t) {
      const float r = input.range[static_cast<std::size_t>(q.index[t])];
      index.push_back(q.index[t]);
      offsets.push_back(q.offset[t][0]);
      offsets.push_back(q.offset[t][1]);
      ranges.push_back(r / mr * 2.0f - 1.0f);
      valid.push_back(r > 0.0f ? 1 : 0);
    }
  }
  if (todo.empty()) return out;
  const auto t1 = Clock::now();
  const auto n = static_cast<std::int64_t>(todo.size());
  const auto image = imageTensor(input, mr);
  const auto feat = impl_->net->encoder->forward(image);  // once per scan
  const auto t2 = Clock::now();
  const auto c = feat.size(1);
  const auto flat = feat.flatten(2).transpose(1, 2).squeeze(0).contiguous();  // [HW, C]
  const auto idx = torch::from_blob(index.data(), {n * 4}, torch::kInt64);
  const auto off = torch::from_blob(offsets.data(), {n, 4, 2}, torch::kFloat32);
  const auto rng = torch::from_blob(ranges.data(), {n, 4}, torch::kFloat32);
  const auto val = torch::from_blob(valid.data(), {n, 4}, torch::kUInt8).to(torch::kBool);
  if (use_fast_head_) {
    std::vector<float> predicted(static_cast<std::size_t>(n));
    impl_->fastHead().predict({flat.data_ptr<float>(), index.data(), offsets.data(), ranges.data(),
                               valid.data(), static_cast<std::size_t>(n)},
                              predicted.data());
    for (std::size_t i = 0; i < predicted.size(); ++i)
      out.range[static_cast<std::size_t>(todo[i])] = (predicted[i] + 1.0f) * (mr / 2.0f);
  } else {
    const auto tokens = flat.index_select(0, idx).view({n, 4, c});
    const auto scores = impl_->net->head->forward(tokens, off).masked_fill(val.logical_not(), -1e9);
    const auto pred = ((torch::softmax(scores, -1) * rng).sum(-1) + 1.0) * (mr / 2.0);
    const auto acc = pred.contiguous();
    const float* p = acc.data_ptr<float>();
    for (std::int64_t i = 0; i < n; ++i)
      out.range[static_cast<std::size_t>(todo[static_cast<std::size_t>(i)])] = p[i];
  }
  const auto t3 = Clock::now();
  spdlog::debug("ILN upsample: queries {:.1f} ms, encoder {:.1f} ms, weights for {} queries {:.1f} ms",
                ms(t0, t1), ms(t1, t2), n, ms(t2, t3));
  return out;
}

double IlnUpsampler::trainStep(const std::vector<RangeImagePair>& examples, const IlnTrainOptions& options,
                               std::mt19937& rng) {
  if (examples.empty()) throw std::invalid_argument("ILN training needs examples");
  impl_->net->train();
  const float mr = impl_->options.max_range;
  const int batch = std::max(1, options.batch);
  const int qn = std::max(1, options.queries_per_example);
  std::vector<torch::Tensor> images;
  std::vector<std::int64_t> index;
  std::vector<float> offsets, ranges, targets;
  std::vector<std::uint8_t> valid;
  std::uniform_int_distribution<std::size_t> pick(0, examples.size() - 1);
  int crop_rows = 0;
  const int crop_cols = options.crop_columns;
  for (int b = 0; b < batch; ++b) {
    const RangeImagePair& ex = examples[pick(rng)];
    const int cols = ex.input.columns();
    const int cw = std::min(crop_cols, cols);
    crop_rows = ex.input.rows();
    const int c0 = std::uniform_int_distribution<int>(0, cols - cw)(rng);
    // The crop of the input image.
    RangeImage crop(ex.input.geometry);
    crop.geometry.columns = cw;
    crop.range.assign(static_cast<std::size_t>(crop_rows) * static_cast<std::size_t>(cw), 0.0f);
    for (int i = 0; i < crop_rows; ++i)
      for (int j = 0; j < cw; ++j) crop.at(i, j) = ex.input.at(i, c0 + j);
    images.push_back(imageTensor(crop, mr));
    // Target pixels whose 4 neighbours lie inside the crop, with a return and some measured neighbour.
    const auto queries = queryNeighbours(ex.input.geometry, ex.target.geometry);
    std::vector<std::size_t> candidates;
    for (std::size_t k = 0; k < queries.size(); ++k) {
      if (!(ex.target.range[k] > 0.0f)) continue;
      const int left = queries[k].index[0] % cols, right = queries[k].index[1] % cols;
      if (left < c0 || right < c0 || left >= c0 + cw || right >= c0 + cw) continue;
      bool any = false;
      for (std::size_t t = 0; t < 4; ++t)
        any = any || ex.input.range[static_cast<std::size_t>(queries[k].index[t])] > 0.0f;
      if (any) candidates.push_back(k);
    }
    for (int s = 0; s < qn; ++s) {
      if (candidates.empty()) {
        // No usable pixel in this crop: pad with a masked dummy query (zero weight in the loss).
        for (int t = 0; t < 4; ++t) {
          index.push_back(0);
          offsets.insert(offsets.end(), {0.0f, 0.0f});
          ranges.push_back(-1.0f);
          valid.push_back(t == 0 ? 1 : 0);
        }
        targets.push_back(std::nanf(""));
        continue;
      }
      const std::size_t k =
          candidates[std::uniform_int_distribution<std::size_t>(0, candidates.size() - 1)(rng)];
      const QueryNeighbours& q = queries[k];
      for (std::size_t t = 0; t < 4; ++t) {
        const int row = q.index[t] / cols, col = q.index[t] % cols - c0;
        const float r = ex.input.range[static_cast<std::size_t>(q.index[t])];
        index.push_back(row * cw + col);
        offsets.push_back(q.offset[t][0]);
        offsets.push_back(q.offset[t][1]);
        ranges.push_back(r / mr * 2.0f - 1.0f);
        valid.push_back(r > 0.0f ? 1 : 0);
      }
      targets.push_back(ex.target.range[k] / mr * 2.0f - 1.0f);
    }
  }
  const auto image = torch::cat(images, 0);
  const auto idx = torch::from_blob(index.data(), {batch, qn, 4}, torch::kInt64);
  const auto off = torch::from_blob(offsets.data(), {batch, qn, 4, 2}, torch::kFloat32);
  const auto rgs = torch::from_blob(ranges.data(), {batch, qn, 4}, torch::kFloat32);
  const auto val = torch::from_blob(valid.data(), {batch, qn, 4}, torch::kUInt8).to(torch::kBool);
  auto tgt = torch::from_blob(targets.data(), {batch, qn}, torch::kFloat32);
  const auto keep = tgt.isnan().logical_not();
  const auto pred = impl_->net->forward(image, idx, off, rgs, val);
  // L1 loss on normalised ranges (Sec. 4.3), over the real queries.
  const auto loss = (pred - tgt.nan_to_num(0.0)).abs().masked_select(keep).mean();
  auto& adam = impl_->optimizer(options.learning_rate);
  adam.zero_grad();
  loss.backward();
  adam.step();
  ++impl_->step;
  return loss.item<double>() * mr / 2.0;
}

}  // namespace densemap::densify
