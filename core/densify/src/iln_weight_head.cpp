#include "densemap/densify/iln_weight_head.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

namespace densemap::densify {

namespace {

constexpr int kB = IlnWeightHead::kBlock;
constexpr int kT = 4 * kB;  // tokens per block; token t of query q is column t * kB + q

inline float expInline(float x) {
  x = std::min(std::max(x, -87.0f), 88.0f);
  // x = n ln2 + r, |r| <= ln2 / 2; n rounded with the 1.5 * 2^23 trick (no call to round()).
  const float n = (x * 1.44269504f + 12582912.0f) - 12582912.0f;
  const float r = (x - n * 0.693359375f) + n * 2.12194440e-4f;  // ln2 in two parts (Cody and Waite)
  // Taylor to degree 7: the remainder is below 1e-8 relative on |r| <= 0.347.
  float p = 1.0f / 5040.0f;
  p = p * r + 1.0f / 720.0f;
  p = p * r + 1.0f / 120.0f;
  p = p * r + 1.0f / 24.0f;
  p = p * r + 1.0f / 6.0f;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  return p * std::bit_cast<float>((static_cast<int>(n) + 127) << 23);
}

inline float erfInline(float x) {
  const float a = std::abs(x);
  const float t = 1.0f / (1.0f + 0.3275911f * a);
  float p = 1.061405429f;
  p = p * t - 1.453152027f;
  p = p * t + 1.421413741f;
  p = p * t - 0.284496736f;
  p = p * t + 0.254829592f;
  const float y = 1.0f - p * t * expInline(-a * a);
  return x < 0.0f ? -y : y;
}

/// out[r][col] = b[r] + sum_i w[r][i] in[i][col], over a block's kT columns. The sums build up in a local
/// row the compiler keeps in vector registers (accumulating in `out` costs a load and a store per step).
inline void affine(const float* __restrict w, const float* __restrict b, const float* __restrict in, int rows,
                   int cols, float* __restrict out) {
  for (int r = 0; r < rows; ++r) {
    float acc[kT];
    for (int col = 0; col < kT; ++col) acc[col] = b[r];
    for (int i = 0; i < cols; ++i) {
      const float wi = w[static_cast<std::ptrdiff_t>(r) * cols + i];
      const float* x = in + static_cast<std::ptrdiff_t>(i) * kT;
      for (int col = 0; col < kT; ++col) acc[col] += wi * x[col];
    }
    std::copy_n(acc, kT, out + static_cast<std::ptrdiff_t>(r) * kT);
  }
}

inline void layerNorm(const float* in, const float* g, const float* b, int c, float* mean, float* inv,
                      float* out) {
  for (int col = 0; col < kT; ++col) mean[col] = 0.0f, inv[col] = 0.0f;
  for (int i = 0; i < c; ++i)
    for (int col = 0; col < kT; ++col) mean[col] += in[i * kT + col];
  for (int col = 0; col < kT; ++col) mean[col] /= static_cast<float>(c);
  for (int i = 0; i < c; ++i)
    for (int col = 0; col < kT; ++col) {
      const float d = in[i * kT + col] - mean[col];
      inv[col] += d * d;
    }
  for (int col = 0; col < kT; ++col)
    inv[col] = 1.0f / std::sqrt(inv[col] / static_cast<float>(c) + 1e-5f);  // torch's default eps
  for (int i = 0; i < c; ++i)
    for (int col = 0; col < kT; ++col)
      out[i * kT + col] = (in[i * kT + col] - mean[col]) * inv[col] * g[i] + b[i];
}

/// Per-thread working memory for one block, [rows][kT] each.
struct Scratch {
  Scratch(int c, int mlp)
      : x(static_cast<std::size_t>(c) * kT),
        y(x.size()),
        qkv(3 * x.size()),
        mixed(x.size()),
        tmp(x.size()),
        hidden(static_cast<std::size_t>(mlp) * kT) {}
  std::vector<float> x, y, qkv, mixed, tmp, hidden;
  float mean[kT], inv[kT], score[kT], range[kT];
};

// Compiled twice on x86-64, for the baseline and for AVX2 (8 floats per instruction instead of 4), the
// loader picking the one the CPU runs; the arithmetic is the same, without fused multiply-adds.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DENSEMAP_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define DENSEMAP_VECTOR_CLONES
#endif

DENSEMAP_VECTOR_CLONES
void predictBlock(const IlnWeightHeadParameters& p, const IlnHeadQueries& in, std::size_t first, Scratch& s,
                  float* out) {
  const int c = p.channels, hd = c / p.heads;
  const std::size_t count = std::min<std::size_t>(kB, in.count - first);
  // Gather the tokens and embed their offsets; a short last block repeats its first query.
  for (int q = 0; q < kB; ++q) {
    const std::size_t k = first + (static_cast<std::size_t>(q) < count ? static_cast<std::size_t>(q) : 0);
    for (int t = 0; t < 4; ++t) {
      const int col = t * kB + q;
      const float* f = in.features + in.pixel[k * 4 + static_cast<std::size_t>(t)] * c;
      const float ox = in.offsets[k * 8 + static_cast<std::size_t>(2 * t)];
      const float oy = in.offsets[k * 8 + static_cast<std::size_t>(2 * t + 1)];
      for (int i = 0; i < c; ++i)
        s.x[static_cast<std::size_t>(i * kT + col)] = f[i] + p.embed_w[static_cast<std::size_t>(2 * i)] * ox +
                                                      p.embed_w[static_cast<std::size_t>(2 * i + 1)] * oy +
                                                      p.embed_b[static_cast<std::size_t>(i)];
      const bool valid = in.valid[k * 4 + static_cast<std::size_t>(t)] != 0;
      s.range[col] = in.ranges[k * 4 + static_cast<std::size_t>(t)];
      s.score[col] = valid ? 0.0f : -1e9f;  // the mask, added to the score below
    }
  }
  float* x = s.x.data();
  float* y = s.y.data();
  float* qkv = s.qkv.data();
  layerNorm(x, p.norm1_g.data(), p.norm1_b.data(), c, s.mean, s.inv, y);
  affine(p.qkv_w.data(), p.qkv_b.data(), y, 3 * c, c, qkv);
  // Self-attention among each query's 4 tokens, per head, vectorised across the block's queries.
  const float scale = 1.0f / std::sqrt(static_cast<float>(hd));
  for (int h = 0; h < p.heads; ++h) {
    for (int i = 0; i < 4; ++i) {
      float a[4][kB];
      for (int j = 0; j < 4; ++j) {
        for (int q = 0; q < kB; ++q) a[j][q] = 0.0f;
        for (int d = 0; d < hd; ++d) {
          const float* qi = qkv + (h * hd + d) * kT + i * kB;
          const float* kj = qkv + (c + h * hd + d) * kT + j * kB;
          for (int q = 0; q < kB; ++q) a[j][q] += qi[q] * kj[q];
        }
      }
      float z[kB];
      for (int q = 0; q < kB; ++q) {
        const float m = std::max(std::max(a[0][q], a[1][q]), std::max(a[2][q], a[3][q]));
        z[q] = 0.0f;
        for (int j = 0; j < 4; ++j) z[q] += (a[j][q] = expInline((a[j][q] - m) * scale));
        z[q] = 1.0f / z[q];
      }
      for (int d = 0; d < hd; ++d) {
        float* mix = s.mixed.data() + (h * hd + d) * kT + i * kB;
        for (int q = 0; q < kB; ++q) mix[q] = 0.0f;
        for (int j = 0; j < 4; ++j) {
          const float* vj = qkv + (2 * c + h * hd + d) * kT + j * kB;
          for (int q = 0; q < kB; ++q) mix[q] += a[j][q] * vj[q];
        }
        for (int q = 0; q < kB; ++q) mix[q] *= z[q];
      }
    }
  }
  float* tmp = s.tmp.data();
  affine(p.proj_w.data(), p.proj_b.data(), s.mixed.data(), c, c, tmp);
  for (int k = 0; k < c * kT; ++k) x[k] += tmp[k];
  layerNorm(x, p.norm2_g.data(), p.norm2_b.data(), c, s.mean, s.inv, y);
  float* hidden = s.hidden.data();
  affine(p.fc1_w.data(), p.fc1_b.data(), y, p.mlp, c, hidden);
  for (int k = 0; k < p.mlp * kT; ++k)  // exact (erf) GELU, as torch's default
    hidden[k] = 0.5f * hidden[k] * (1.0f + erfInline(hidden[k] * 0.70710678f));
  affine(p.fc2_w.data(), p.fc2_b.data(), hidden, c, p.mlp, tmp);
  for (int k = 0; k < c * kT; ++k) x[k] += tmp[k];
  layerNorm(x, p.norm3_g.data(), p.norm3_b.data(), c, s.mean, s.inv, y);
  float sc[kT];
  affine(p.score_w.data(), p.score_b.data(), y, 1, c, sc);
  for (int col = 0; col < kT; ++col) sc[col] += s.score[col];
  // Eq. 4.3: softmax over the 4 scores weights the measured neighbour ranges.
  float result[kB];
  for (int q = 0; q < kB; ++q) {
    const float m = std::max(std::max(sc[q], sc[kB + q]), std::max(sc[2 * kB + q], sc[3 * kB + q]));
    float z = 0.0f, r = 0.0f;
    for (int t = 0; t < 4; ++t) {
      const float e = expInline(sc[t * kB + q] - m);
      z += e;
      r += e * s.range[t * kB + q];
    }
    result[q] = r / z;
  }
  std::copy_n(result, count, out + first);
}

void requireSize(const std::vector<float>& v, std::size_t n, const char* name) {
  if (v.size() != n)
    throw std::invalid_argument(std::string("ILN weight head: ") + name + " has " + std::to_string(v.size()) +
                                " values, expected " + std::to_string(n));
}

}  // namespace

IlnWeightHead::IlnWeightHead(IlnWeightHeadParameters parameters) : p_(std::move(parameters)) {
  if (p_.channels < 1 || p_.heads < 1 || p_.channels % p_.heads != 0 || p_.mlp < 1)
    throw std::invalid_argument("ILN weight head: channels must be a positive multiple of heads, mlp >= 1");
  const auto c = static_cast<std::size_t>(p_.channels), m = static_cast<std::size_t>(p_.mlp);
  requireSize(p_.embed_w, 2 * c, "embed weight");
  requireSize(p_.embed_b, c, "embed bias");
  for (const auto* v : {&p_.norm1_g, &p_.norm1_b, &p_.norm2_g, &p_.norm2_b, &p_.norm3_g, &p_.norm3_b})
    requireSize(*v, c, "a LayerNorm parameter");
  requireSize(p_.qkv_w, 3 * c * c, "qkv weight");
  requireSize(p_.qkv_b, 3 * c, "qkv bias");
  requireSize(p_.proj_w, c * c, "proj weight");
  requireSize(p_.proj_b, c, "proj bias");
  requireSize(p_.fc1_w, m * c, "fc1 weight");
  requireSize(p_.fc1_b, m, "fc1 bias");
  requireSize(p_.fc2_w, c * m, "fc2 weight");
  requireSize(p_.fc2_b, c, "fc2 bias");
  requireSize(p_.score_w, c, "score weight");
  requireSize(p_.score_b, 1, "score bias");
}

void IlnWeightHead::predict(const IlnHeadQueries& queries, float* out) const {
  const auto blocks = static_cast<std::int64_t>((queries.count + kB - 1) / kB);
#pragma omp parallel
  {
    Scratch scratch(p_.channels, p_.mlp);
#pragma omp for schedule(static)
    for (std::int64_t b = 0; b < blocks; ++b)
      predictBlock(p_, queries, static_cast<std::size_t>(b) * kB, scratch, out);
  }
}

namespace detail {
float vectorisableExp(float x) { return expInline(x); }
float vectorisableErf(float x) { return erfInline(x); }
}  // namespace detail

}  // namespace densemap::densify
