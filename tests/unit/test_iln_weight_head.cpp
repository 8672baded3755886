// The block-vectorised ILN weight head (densify/iln_weight_head.h). test_densify checks it against the torch
// modules on real network sizes; here: its exp and erf, blocks of any length, masking and bad parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>

#include "densemap/densify/iln_weight_head.h"

namespace densemap::densify {
namespace {

IlnWeightHeadParameters randomParameters(int c, int heads, int mlp, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> w(0.0f, 0.4f);
  const auto fill = [&](std::size_t n) {
    std::vector<float> v(n);
    for (float& x : v) x = w(rng);
    return v;
  };
  const auto cc = static_cast<std::size_t>(c), m = static_cast<std::size_t>(mlp);
  IlnWeightHeadParameters p;
  p.channels = c, p.heads = heads, p.mlp = mlp;
  p.embed_w = fill(2 * cc), p.embed_b = fill(cc);
  p.norm1_g = fill(cc), p.norm1_b = fill(cc);
  p.qkv_w = fill(3 * cc * cc), p.qkv_b = fill(3 * cc);
  p.proj_w = fill(cc * cc), p.proj_b = fill(cc);
  p.norm2_g = fill(cc), p.norm2_b = fill(cc);
  p.fc1_w = fill(m * cc), p.fc1_b = fill(m);
  p.fc2_w = fill(cc * m), p.fc2_b = fill(cc);
  p.norm3_g = fill(cc), p.norm3_b = fill(cc);
  p.score_w = fill(cc), p.score_b = fill(1);
  return p;
}

/// Random queries over a random feature image of `pixels` pixels.
struct QuerySet {
  QuerySet(std::size_t n, int c, std::size_t pixels, std::uint32_t seed)
      : features(pixels * static_cast<std::size_t>(c)) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> f(0.0f, 1.0f);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::uniform_int_distribution<std::int64_t> px(0, static_cast<std::int64_t>(pixels) - 1);
    for (float& x : features) x = f(rng);
    for (std::size_t k = 0; k < n * 4; ++k) {
      pixel.push_back(px(rng));
      offsets.push_back(u(rng));
      offsets.push_back(u(rng));
      ranges.push_back(u(rng));
      valid.push_back(rng() % 5 != 0 ? 1 : 0);
    }
    for (std::size_t k = 0; k < n; ++k) valid[k * 4] = 1;  // every query has a measured neighbour
  }
  IlnHeadQueries view(std::size_t first, std::size_t count) const {
    return {features.data(),           pixel.data() + first * 4, offsets.data() + first * 8,
            ranges.data() + first * 4, valid.data() + first * 4, count};
  }
  std::vector<float> features;
  std::vector<std::int64_t> pixel;
  std::vector<float> offsets, ranges;
  std::vector<std::uint8_t> valid;
};

TEST(IlnWeightHead, ExpAndErfMatchTheLibraryOnesToFloatPrecision) {
  double worst_exp = 0, worst_erf = 0;
  for (float x = -87.0f; x <= 88.0f; x += 0.0137f) {
    const double ref = std::exp(static_cast<double>(x));
    worst_exp = std::max(worst_exp, std::abs(detail::vectorisableExp(x) - ref) / ref);
  }
  for (float x = -6.0f; x <= 6.0f; x += 0.0011f)
    worst_erf = std::max(worst_erf, std::abs(detail::vectorisableErf(x) - std::erf(static_cast<double>(x))));
  EXPECT_LT(worst_exp, 2e-7);
  EXPECT_LT(worst_erf, 5e-7);  // 7.1.26 is good to 1.5e-7; float arithmetic adds the rest
  EXPECT_EQ(detail::vectorisableErf(0.0f), 0.0f);
  EXPECT_GT(detail::vectorisableExp(-200.0f), 0.0f);  // clamped, not garbage
}

TEST(IlnWeightHead, EachQueryGetsTheSameAnswerWhateverBlockItSitsIn) {
  const IlnWeightHead head(randomParameters(16, 2, 32, 11));
  const QuerySet set(53, 16, 200, 12);  // three full blocks of 16 and a short one of 5
  std::vector<float> together(53);
  head.predict(set.view(0, 53), together.data());
  for (std::size_t k = 0; k < 53; ++k) {
    float alone = 0;
    head.predict(set.view(k, 1), &alone);
    EXPECT_NEAR(together[k], alone, 1e-6f) << "query " << k;
  }
}

TEST(IlnWeightHead, PredictionsAreConvexCombinationsOfTheValidNeighboursOnly) {
  for (const auto& [c, heads, mlp] : {std::tuple{16, 2, 32}, std::tuple{32, 4, 48}, std::tuple{8, 1, 8}}) {
    const IlnWeightHead head(randomParameters(c, heads, mlp, 21));
    QuerySet set(40, c, 100, 22);
    std::vector<float> out(40);
    head.predict(set.view(0, 40), out.data());
    for (std::size_t k = 0; k < 40; ++k) {
      float lo = 2, hi = -2;
      for (std::size_t t = 0; t < 4; ++t)
        if (set.valid[k * 4 + t])
          lo = std::min(lo, set.ranges[k * 4 + t]), hi = std::max(hi, set.ranges[k * 4 + t]);
      EXPECT_GE(out[k], lo - 1e-5f);
      EXPECT_LE(out[k], hi + 1e-5f);
    }
    // One valid neighbour: all the weight is its, whatever the others' ranges.
    for (std::size_t k = 0; k < 40; ++k) {
      set.valid[k * 4] = 1, set.valid[k * 4 + 1] = set.valid[k * 4 + 2] = set.valid[k * 4 + 3] = 0;
      set.ranges[k * 4 + 1] = 0.9f;
    }
    head.predict(set.view(0, 40), out.data());
    for (std::size_t k = 0; k < 40; ++k) EXPECT_NEAR(out[k], set.ranges[k * 4], 1e-6f);
  }
}

TEST(IlnWeightHead, ParametersOfTheWrongSizeAreRefusedNamingWhichOne) {
  auto p = randomParameters(16, 2, 32, 31);
  p.fc2_w.pop_back();
  try {
    IlnWeightHead head(p);
    FAIL() << "accepted a short fc2 weight";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fc2 weight"), std::string::npos) << e.what();
  }
  auto q = randomParameters(16, 3, 32, 32);  // 16 channels do not split into 3 heads
  EXPECT_THROW(IlnWeightHead{q}, std::invalid_argument);
}

}  // namespace
}  // namespace densemap::densify
