// The server's scan pipeline without DDS: overflow policies, per-robot fairness, outcomes and shutdown.
#include <atomic>
#include <condition_variable>
#include <thread>

#include <gtest/gtest.h>

#include "densemap/server/pipeline.h"

namespace densemap::server {
namespace {

using namespace std::chrono_literals;

/// A stage that holds each scan until released, and records the order it saw them in.
class GateStage : public PipelineStage {
 public:
  std::string name() const override { return "gate"; }
  bool commitsToMap() const override { return true; }
  StageResult process(ScanJob& job) override {
    std::unique_lock lock(mutex_);
    entered_ = true;
    entered_cv_.notify_all();
    cv_.wait(lock, [&] { return open_; });
    order_.push_back(job.robot_id + "#" + std::to_string(job.seq));
    if (job.seq == reject_seq_) return StageResult::reject("rejected by the test");
    return {};
  }
  void open() {
    std::lock_guard lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }
  void waitEntered() {
    std::unique_lock lock(mutex_);
    entered_cv_.wait(lock, [&] { return entered_; });
  }
  std::vector<std::string> order() {
    std::lock_guard lock(mutex_);
    return order_;
  }
  std::uint64_t reject_seq_ = ~0ull;

 private:
  std::mutex mutex_;
  std::condition_variable cv_, entered_cv_;
  bool open_ = false, entered_ = false;
  std::vector<std::string> order_;
};

struct Outcomes {
  std::mutex mutex;
  std::vector<std::pair<std::string, ScanOutcome>> list;
  Pipeline::OutcomeListener listener() {
    return [this](const ScanJob& j, ScanOutcome o, const std::string&) {
      std::lock_guard lock(mutex);
      list.emplace_back(j.robot_id + "#" + std::to_string(j.seq), o);
    };
  }
  std::size_t count(ScanOutcome o) {
    std::lock_guard lock(mutex);
    return static_cast<std::size_t>(
        std::count_if(list.begin(), list.end(), [&](auto& p) { return p.second == o; }));
  }
};

ScanJob job(const std::string& robot, std::uint64_t seq) {
  ScanJob j;
  j.robot_id = robot;
  j.seq = seq;
  return j;
}

std::unique_ptr<Pipeline> makePipeline(PipelineOptions o, GateStage*& gate, Outcomes& outcomes) {
  auto stage = std::make_unique<GateStage>();
  gate = stage.get();
  std::vector<std::unique_ptr<PipelineStage>> stages;
  stages.push_back(std::move(stage));
  return std::make_unique<Pipeline>(o, std::move(stages), outcomes.listener());
}

TEST(Pipeline, DropOldestKeepsTheNewestScansAndCountsEveryDrop) {
  PipelineOptions o;
  o.robot_queue_capacity = 2;
  o.overflow = OverflowPolicy::kDropOldest;
  Outcomes outcomes;
  GateStage* gate = nullptr;
  auto p = makePipeline(o, gate, outcomes);
  p->submit(job("r", 0));
  gate->waitEntered();  // scan 0 is in the stage; the queue is empty
  for (std::uint64_t s = 1; s <= 5; ++s) p->submit(job("r", s));
  EXPECT_EQ(outcomes.count(ScanOutcome::kDropped), 3u);  // 1, 2, 3 pushed out by 4, 5
  gate->open();
  p->stop(true);
  EXPECT_EQ(gate->order(), (std::vector<std::string>{"r#0", "r#4", "r#5"}));
  const auto c = p->robotCounters().at("r");
  EXPECT_EQ(c.received, 6u);
  EXPECT_EQ(c.processed, 3u);
  EXPECT_EQ(c.dropped, 3u);
  EXPECT_EQ(outcomes.count(ScanOutcome::kInMap), 3u);
}

TEST(Pipeline, WaitPolicyBlocksTheProducerAndLosesNothing) {
  PipelineOptions o;
  o.robot_queue_capacity = 1;
  o.overflow = OverflowPolicy::kWait;
  Outcomes outcomes;
  GateStage* gate = nullptr;
  auto p = makePipeline(o, gate, outcomes);
  p->submit(job("r", 0));
  gate->waitEntered();
  p->submit(job("r", 1));  // fills the queue
  std::atomic<bool> returned{false};
  std::thread producer([&] {
    p->submit(job("r", 2));
    returned = true;
  });
  std::this_thread::sleep_for(200ms);
  EXPECT_FALSE(returned) << "a full queue under the wait policy must block the producer";
  gate->open();
  producer.join();
  p->stop(true);
  EXPECT_EQ(gate->order(), (std::vector<std::string>{"r#0", "r#1", "r#2"}));
  EXPECT_EQ(p->robotCounters().at("r").dropped, 0u);
}

TEST(Pipeline, RobotsAreServedRoundRobin) {
  PipelineOptions o;
  o.robot_queue_capacity = 8;
  Outcomes outcomes;
  GateStage* gate = nullptr;
  auto p = makePipeline(o, gate, outcomes);
  p->submit(job("a", 0));
  gate->waitEntered();
  for (std::uint64_t s = 1; s <= 3; ++s) p->submit(job("a", s));
  for (std::uint64_t s = 0; s < 3; ++s) p->submit(job("b", s));
  gate->open();
  p->stop(true);
  // After a#0, robot b is next in turn, then they alternate.
  EXPECT_EQ(gate->order(), (std::vector<std::string>{"a#0", "b#0", "a#1", "b#1", "a#2", "b#2", "a#3"}));
}

TEST(Pipeline, StopWithoutDrainDropsQueuedScansCounted) {
  PipelineOptions o;
  o.robot_queue_capacity = 8;
  Outcomes outcomes;
  GateStage* gate = nullptr;
  auto p = makePipeline(o, gate, outcomes);
  p->submit(job("r", 0));
  gate->waitEntered();
  for (std::uint64_t s = 1; s <= 4; ++s) p->submit(job("r", s));
  std::thread stopper([&] { p->stop(false); });
  for (int i = 0; i < 500 && outcomes.count(ScanOutcome::kDropped) < 4; ++i)
    std::this_thread::sleep_for(10ms);
  gate->open();
  stopper.join();
  EXPECT_EQ(gate->order(), (std::vector<std::string>{"r#0"}));
  EXPECT_EQ(p->robotCounters().at("r").dropped, 4u);
  EXPECT_EQ(outcomes.count(ScanOutcome::kDropped), 4u);
  EXPECT_FALSE(p->submit(job("r", 9))) << "a stopped pipeline takes no scans";
}

TEST(Pipeline, StageRejectionsAreCountedAndReported) {
  PipelineOptions o;
  Outcomes outcomes;
  GateStage* gate = nullptr;
  auto p = makePipeline(o, gate, outcomes);
  gate->reject_seq_ = 1;
  gate->open();
  for (std::uint64_t s = 0; s < 3; ++s) p->submit(job("r", s));
  p->stop(true);
  const auto c = p->robotCounters().at("r");
  EXPECT_EQ(c.processed, 2u);
  EXPECT_EQ(c.rejected, 1u);
  EXPECT_EQ(outcomes.count(ScanOutcome::kRejected), 1u);
  EXPECT_EQ(p->inFlight(), 0u);
}

}  // namespace
}  // namespace densemap::server
