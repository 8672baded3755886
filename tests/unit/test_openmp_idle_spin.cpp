// The server's idle-spin setting for libgomp: when it re-executes itself and when the environment decides.
#include <gtest/gtest.h>

#include "densemap/server/openmp_idle_spin.h"

namespace densemap::server {
namespace {

TEST(OpenmpIdleSpin, ConfiguredValueIsPutInTheEnvironmentWhenNothingIsSet) {
  const auto plan = planOpenmpIdleSpin(0, nullptr, nullptr);
  ASSERT_TRUE(plan.spin_count.has_value());
  EXPECT_EQ(*plan.spin_count, "0");
  EXPECT_EQ(planOpenmpIdleSpin(20000, nullptr, nullptr).spin_count.value_or(""), "20000");
}

TEST(OpenmpIdleSpin, AfterTheReExecutionNothingMoreHappens) {
  // The re-executed server sees its own value: no second execution (no loop).
  const auto plan = planOpenmpIdleSpin(20000, nullptr, "20000");
  EXPECT_FALSE(plan.spin_count.has_value());
  EXPECT_NE(plan.message.find("20000"), std::string::npos);
  EXPECT_EQ(plan.message.find("wins"), std::string::npos) << plan.message;
}

TEST(OpenmpIdleSpin, TheUsersEnvironmentWinsAndTheLogSaysSo) {
  const auto by_count = planOpenmpIdleSpin(0, nullptr, "500");
  EXPECT_FALSE(by_count.spin_count.has_value());
  EXPECT_NE(by_count.message.find("GOMP_SPINCOUNT=500"), std::string::npos) << by_count.message;
  EXPECT_NE(by_count.message.find("wins over --update-idle-spin 0"), std::string::npos) << by_count.message;
  const auto by_policy = planOpenmpIdleSpin(0, "active", nullptr);
  EXPECT_FALSE(by_policy.spin_count.has_value());
  EXPECT_NE(by_policy.message.find("OMP_WAIT_POLICY=active"), std::string::npos) << by_policy.message;
}

TEST(OpenmpIdleSpin, MinusOneLeavesLibgompsDefault) {
  const auto plan = planOpenmpIdleSpin(-1, nullptr, nullptr);
  EXPECT_FALSE(plan.spin_count.has_value());
  EXPECT_NE(plan.message.find("default"), std::string::npos);
}

}  // namespace
}  // namespace densemap::server
