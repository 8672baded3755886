// ILN's weight head (Secs. 4.3.1-4.3.3) for inference, written out in plain C++ and evaluated on blocks of
// queries at once, so that every step is a loop over the block that the compiler vectorises. libtorch
// trains the head; this computes the same function from its parameters without libtorch's per-operator
// overhead (tests compare the two).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace densemap::densify {

/// The trained parameters, each Linear weight in torch's layout ([out][in], row-major).
struct IlnWeightHeadParameters {
  int channels = 0;                     ///< token width C
  int heads = 1;                        ///< attention heads (C / heads dims each)
  int mlp = 0;                          ///< MLP width
  std::vector<float> embed_w, embed_b;  ///< [C][2], [C]: offset embedding
  std::vector<float> norm1_g, norm1_b;  ///< [C]
  std::vector<float> qkv_w, qkv_b;      ///< [3C][C], [3C]
  std::vector<float> proj_w, proj_b;    ///< [C][C], [C]
  std::vector<float> norm2_g, norm2_b;  ///< [C]
  std::vector<float> fc1_w, fc1_b;      ///< [mlp][C], [mlp]
  std::vector<float> fc2_w, fc2_b;      ///< [C][mlp], [C]
  std::vector<float> norm3_g, norm3_b;  ///< [C]
  std::vector<float> score_w, score_b;  ///< [1][C], [1]
};

/// One query: its 4 neighbouring input pixels.
struct IlnHeadQueries {
  const float* features = nullptr;      ///< encoder output, [pixels][C]
  const std::int64_t* pixel = nullptr;  ///< [n][4] pixel of each neighbour
  const float* offsets = nullptr;       ///< [n][4][2] query offset from each neighbour (input-pixel units)
  const float* ranges = nullptr;        ///< [n][4] neighbour ranges, normalised to [-1, 1]
  const std::uint8_t* valid = nullptr;  ///< [n][4] 1 where the neighbour has a return
  std::size_t count = 0;                ///< n
};

class IlnWeightHead {
 public:
  /// Throws std::invalid_argument when a parameter has the wrong size.
  explicit IlnWeightHead(IlnWeightHeadParameters parameters);

  /// Queries evaluated together: the vector width of every step (a multiple of 16 floats).
  static constexpr int kBlock = 16;

  /// out[k] = Eq. 4.3's convex combination of query k's valid neighbour ranges (normalised), for every
  /// query; spreads the blocks over the OpenMP threads.
  void predict(const IlnHeadQueries& queries, float* out) const;

  const IlnWeightHeadParameters& parameters() const { return p_; }

 private:
  IlnWeightHeadParameters p_;
};

namespace detail {
/// exp and erf in plain arithmetic the compiler can vectorise (glibc's are calls it cannot); relative error
/// of exp below 2e-7 for x in [-87, 88]; absolute error of erf below 5e-7 (Abramowitz and Stegun 7.1.26,
/// 1.5e-7, evaluated in float).
float vectorisableExp(float x);
float vectorisableErf(float x);
}  // namespace detail

}  // namespace densemap::densify
