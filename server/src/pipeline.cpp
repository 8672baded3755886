#include "densemap/server/pipeline.h"
#include "densemap/util/realtime_priority.h"

#include <pthread.h>

#include <chrono>

#include <spdlog/spdlog.h>

namespace densemap::server {

using namespace std::chrono_literals;

std::string_view toString(OverflowPolicy p) { return p == OverflowPolicy::kWait ? "wait" : "drop_oldest"; }

std::optional<OverflowPolicy> parseOverflowPolicy(std::string_view s) {
  if (s == "wait") return OverflowPolicy::kWait;
  if (s == "drop_oldest" || s == "drop-oldest") return OverflowPolicy::kDropOldest;
  return std::nullopt;
}

Pipeline::Pipeline(PipelineOptions options, std::vector<std::unique_ptr<PipelineStage>> stages,
                   OutcomeListener listener)
    : options_(options), listener_(std::move(listener)) {
  if (stages.empty()) throw std::invalid_argument("a pipeline needs at least one stage");
  for (auto& s : stages)
    stages_.push_back(std::make_unique<Stage>(std::move(s), options_.stage_queue_capacity));
  stages_running_ = stages_.size();
  for (std::size_t i = 0; i < stages_.size(); ++i) {
    stages_[i]->worker = std::thread([this, i] { runStage(i); });
  }
}

Pipeline::~Pipeline() { stop(true); }

Pipeline::Robot* Pipeline::robot(const std::string& id) {
  std::lock_guard lock(robots_mutex_);
  auto it = robots_.find(id);
  if (it != robots_.end()) return it->second.get();
  if (robots_.size() >= options_.max_robots) return nullptr;
  auto r = std::make_unique<Robot>(options_);
  r->counters.queue_capacity = options_.robot_queue_capacity;
  Robot* raw = r.get();
  robots_.emplace(id, std::move(r));
  order_.push_back(raw);
  spdlog::info("pipeline: new robot '{}' ({} robots)", id, robots_.size());
  return raw;
}

void Pipeline::rejectAtDoor(const ScanJob& job, const std::string& why) {
  if (Robot* r = robot(job.robot_id); r != nullptr) {
    std::lock_guard lock(robots_mutex_);
    ++r->counters.received;
    ++r->counters.rejected;
    r->counters.points_rejected += job.points_rejected;
    r->counters.last_seq = job.seq;
  }
  spdlog::warn("scan {}#{} rejected: {}", job.robot_id, job.seq, why);
  if (job.on_outcome) job.on_outcome(job, ScanOutcome::kRejected, why);
  if (listener_) listener_(job, ScanOutcome::kRejected, why);
}

bool Pipeline::submit(ScanJob&& job) {
  if (!accepting_) return false;
  Robot* r = robot(job.robot_id);
  if (r == nullptr) {
    rejectAtDoor(job, "too many robots (max_robots = " + std::to_string(options_.max_robots) + ")");
    return true;
  }
  {
    std::lock_guard lock(robots_mutex_);
    ++r->counters.received;
    r->counters.last_seq = job.seq;
  }
  ++in_flight_;
  std::optional<ScanJob> dropped = r->queue.push(std::move(job));
  arrival_.notify_one();
  if (dropped) {
    const bool closed = !accepting_;
    finish(*dropped, ScanOutcome::kDropped,
           closed ? "server shutting down" : "robot queue full (overflow policy drop_oldest)");
  }
  return true;
}

bool Pipeline::submitChange(std::shared_ptr<MapChange> change) {
  {
    std::lock_guard lock(robots_mutex_);
    if (!accepting_) return false;
    changes_.push_back(std::move(change));
  }
  arrival_.notify_one();
  return true;
}

std::optional<ScanJob> Pipeline::nextRoundRobin() {
  std::lock_guard lock(robots_mutex_);
  if (!changes_.empty()) {
    ScanJob job;
    job.change = std::move(changes_.front());
    changes_.pop_front();
    return job;
  }
  // next_robot_ is one past the robot served last (not wrapped, so a robot added since is next in turn).
  for (std::size_t n = 0; n < order_.size(); ++n) {
    const std::size_t i = (next_robot_ + n) % order_.size();
    if (auto job = order_[i]->queue.tryPop()) {
      next_robot_ = i + 1;
      return job;
    }
  }
  return std::nullopt;
}

std::optional<ScanJob> Pipeline::next(std::size_t index, std::chrono::microseconds timeout, bool& finished) {
  if (index > 0) {
    Stage& stage = *stages_[index];
    std::optional<ScanJob> job = stage.input.pop(timeout);
    if (!job && stage.input.closedAndEmpty()) finished = true;
    return job;
  }
  if (auto job = nextRoundRobin()) return job;
  if (!accepting_) {  // stop(): every robot queue has been emptied
    finished = true;
    return std::nullopt;
  }
  std::unique_lock lock(arrival_mutex_);
  arrival_.wait_for(lock, timeout);
  return std::nullopt;
}

void Pipeline::pass(std::size_t index, ScanJob&& job, const StageResult& result) {
  Stage& stage = *stages_[index];
  Stage* next = index + 1 < stages_.size() ? stages_[index + 1].get() : nullptr;
  if (job.change) {
    if (next != nullptr) {
      next->input.push(std::move(job));  // never dropped (the queue keeps commands)
    } else {
      job.change->done.set_value();
    }
    return;
  }
  if (!result.ok) {
    finish(job, result.duplicate ? ScanOutcome::kDuplicate : ScanOutcome::kRejected, result.error);
    return;
  }
  if (stage.impl->commitsToMap()) {
    publish_to_map_.add(static_cast<double>(job.in_map_ns - job.publish_ns) * 1e-6);
    finish(job, ScanOutcome::kInMap, {});
  }
  if (next != nullptr) {
    // Stages after the map commit see a copy only if they need it; the outcome was already reported.
    std::optional<ScanJob> dropped = next->input.push(std::move(job));
    if (dropped) {
      ++next->dropped;
      spdlog::debug("stage {}: dropped scan {}#{} (falling behind)", next->impl->name(), dropped->robot_id,
                    dropped->seq);
    }
  }
}

void Pipeline::runStage(std::size_t index) {
  Stage& stage = *stages_[index];
  Stage* next_stage = index + 1 < stages_.size() ? stages_[index + 1].get() : nullptr;
  // Named so profiles and load-test reports attribute CPU per stage (Linux allows 15 characters).
  pthread_setname_np(pthread_self(), ("dm-" + stage.impl->name()).substr(0, 15).c_str());
  // Bulk work: normal scheduling and the kernel's default slice (the server asks real-time priority and a
  // short slice for its latency-bound threads only).
  util::useBulkScheduling();
  const std::optional<std::chrono::microseconds> window = stage.impl->groupWindow();
  constexpr std::size_t kMaxGroup = 64;  // bounds the memory a group holds (scans wait in it)
  bool finished = false;
  while (!finished) {
    std::optional<ScanJob> job = next(index, 10ms, finished);
    if (!job) continue;
    if (window) {
      // A group: every job that arrives within the window after the first, handled in one call (the
      // journal's group commit: one fsync for all of them).
      std::vector<ScanJob> group;
      group.push_back(std::move(*job));
      const auto deadline = std::chrono::steady_clock::now() + *window;
      bool input_done = false;
      while (group.size() < kMaxGroup && !input_done) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline) break;
        auto more =
            next(index, std::chrono::duration_cast<std::chrono::microseconds>(deadline - now), input_done);
        if (more) group.push_back(std::move(*more));
      }
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<StageResult> results;
      stage.impl->processGroup(group, results);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      for (std::size_t i = 0; i < group.size(); ++i) {
        if (!group[i].change) {
          stage.latency.add(ms);
          ++stage.processed;
        }
        pass(index, std::move(group[i]), i < results.size() ? results[i] : StageResult{});
      }
      finished = input_done;
      continue;
    }
    if (job->change) {
      stage.impl->applyChange(*job->change);
      pass(index, std::move(*job), {});
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    StageResult result = stage.impl->process(*job);
    if (!result.passed_through)
      stage.latency.add(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    ++stage.processed;
    pass(index, std::move(*job), result);
  }
  // Drain or drop is decided by stop(); here the stage's input is finished: close the next one.
  if (next_stage != nullptr) next_stage->input.close();
  --stages_running_;
}

void Pipeline::finish(const ScanJob& job, ScanOutcome outcome, const std::string& why) {
  {
    std::lock_guard lock(robots_mutex_);
    auto it = robots_.find(job.robot_id);
    if (it != robots_.end()) {
      RobotCounters& c = it->second->counters;
      c.points_rejected += job.points_rejected;
      if (outcome == ScanOutcome::kInMap) ++c.processed;
      if (outcome == ScanOutcome::kRejected) ++c.rejected;
      if (outcome == ScanOutcome::kDropped) ++c.dropped;
      if (outcome == ScanOutcome::kDuplicate) ++c.duplicates;
    }
  }
  if (outcome == ScanOutcome::kDuplicate) {
    spdlog::info("scan {}#{}: {}", job.robot_id, job.seq, why);
  } else if (outcome != ScanOutcome::kInMap) {
    spdlog::warn("scan {}#{} {}: {}", job.robot_id, job.seq,
                 outcome == ScanOutcome::kDropped ? "dropped" : "rejected", why);
  }
  if (job.on_outcome) job.on_outcome(job, outcome, why);
  if (listener_) listener_(job, outcome, why);
  --in_flight_;
}

void Pipeline::stop(bool drain) {
  std::lock_guard stop_lock(stop_mutex_);
  if (stopped_) return;
  std::vector<Robot*> robots;
  {
    std::lock_guard lock(robots_mutex_);
    accepting_ = false;  // under the lock: a command is either queued before this or refused
    robots = order_;
  }
  for (Robot* r : robots) r->queue.close();  // producers blocked under the wait policy return
  if (!drain) {
    for (Robot* r : robots) {
      while (auto job = r->queue.tryPop()) finish(*job, ScanOutcome::kDropped, "server shutting down");
    }
  }
  arrival_.notify_all();
  for (auto& s : stages_) {
    if (s->worker.joinable()) s->worker.join();
  }
  // A command queued as the first stage was leaving: give it up, said so.
  std::deque<std::shared_ptr<MapChange>> late;
  {
    std::lock_guard lock(robots_mutex_);
    late.swap(changes_);
  }
  for (auto& c : late) {
    c->result.status = Status::kUnavailable;
    c->result.message = "the server is shutting down";
    c->done.set_value();
  }
  stopped_ = true;
}

std::map<std::string, RobotCounters> Pipeline::robotCounters() const {
  std::lock_guard lock(robots_mutex_);
  std::map<std::string, RobotCounters> out;
  for (const auto& [id, r] : robots_) {
    RobotCounters c = r->counters;
    c.queue_depth = r->queue.size();
    out.emplace(id, c);
  }
  return out;
}

std::vector<StageCounters> Pipeline::stageCounters() const {
  std::vector<StageCounters> out;
  for (std::size_t i = 0; i < stages_.size(); ++i) {
    const Stage& s = *stages_[i];
    StageCounters c;
    c.name = s.impl->name();
    c.processed = s.processed;
    c.dropped = s.dropped;
    if (i == 0) {
      std::lock_guard lock(robots_mutex_);
      for (const Robot* r : order_) c.queue_depth += r->queue.size();
    } else {
      c.queue_depth = s.input.size();
    }
    c.latency = s.latency.summary();
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace densemap::server
