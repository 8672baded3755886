// The paired sign test densemap-bench uses to say whether the default method is measurably slower than
// another (eval/paired_timing.h).
#include <gtest/gtest.h>

#include "densemap/eval/paired_timing.h"

namespace densemap::eval {
namespace {

TEST(PairedTiming, SignTestPValuesAreBinomialTails) {
  EXPECT_DOUBLE_EQ(signTestPValue(5, 5), 1.0 / 32.0);
  EXPECT_DOUBLE_EQ(signTestPValue(4, 5), 6.0 / 32.0);
  EXPECT_DOUBLE_EQ(signTestPValue(0, 5), 1.0);
  EXPECT_DOUBLE_EQ(signTestPValue(4, 4), 1.0 / 16.0);
  EXPECT_DOUBLE_EQ(signTestPValue(7, 8), 9.0 / 256.0);
  EXPECT_DOUBLE_EQ(signTestPValue(3, 0), 1.0);  // no rounds: no evidence
}

TEST(PairedTiming, SlowerInEveryOneOfFiveRoundsIsMeasurableAndFourOfFiveIsNot) {
  const std::vector<double> other = {10.0, 12.0, 9.0, 11.0, 10.0};
  const PairedTiming every = comparePaired({10.1, 12.2, 9.1, 11.5, 10.2}, other);
  EXPECT_EQ(every.rounds, 5);
  EXPECT_EQ(every.slower_rounds, 5);
  EXPECT_TRUE(every.measurablySlower());
  EXPECT_NEAR(every.median_ratio, 12.2 / 12.0, 1e-12);  // of 1.01, 1.011, 1.0167, 1.02, 1.045
  // One round the other way: p = 6/32, not measurable even though the median ratio is above 1.
  const PairedTiming four = comparePaired({10.1, 12.2, 8.9, 11.5, 10.2}, other);
  EXPECT_EQ(four.slower_rounds, 4);
  EXPECT_GT(four.median_ratio, 1.0);
  EXPECT_FALSE(four.measurablySlower());
  // Equal times are not slower.
  EXPECT_EQ(comparePaired(other, other).slower_rounds, 0);
  EXPECT_DOUBLE_EQ(comparePaired(other, other).median_ratio, 1.0);
}

TEST(PairedTiming, ThePairsAreTheRoundsNotTheSortedTimes) {
  // The same times paired as measured (first slower in every round) or paired across rounds (3 of 5):
  // what the rounds share (the machine's state then) is what the pairing removes.
  const std::vector<double> a = {8.5, 9.5, 10.5, 11.5, 12.5}, b = {8.0, 9.0, 10.0, 11.0, 12.0};
  const std::vector<double> shuffled_b = {12.0, 8.0, 11.0, 9.0, 10.0};
  EXPECT_TRUE(comparePaired(a, b).measurablySlower());
  EXPECT_FALSE(comparePaired(a, shuffled_b).measurablySlower());
}

TEST(PairedTiming, NonFiniteOrZeroTimesAreLeftOut) {
  const PairedTiming t = comparePaired({1.0, 2.0, std::nan(""), 3.0}, {0.5, 0.0, 1.0, 1.0});
  EXPECT_EQ(t.rounds, 2);
  EXPECT_EQ(t.slower_rounds, 2);
  EXPECT_FALSE(t.measurablySlower());  // two rounds cannot show it
}

}  // namespace
}  // namespace densemap::eval
