#include "densemap/server/durability/journal_stage.h"

#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "densemap/server/durability/journal_record.h"

namespace densemap::server::durability {

JournalStage::JournalStage(std::unique_ptr<JournalWriter> writer, RobotProgress journaled, int sync_ms,
                           std::uint64_t since_snapshot)
    : writer_(std::move(writer)),
      journaled_(std::move(journaled)),
      durable_(journaled_),
      window_(std::chrono::milliseconds(sync_ms)),
      scans_since_snapshot_(since_snapshot) {}

StageResult JournalStage::process(ScanJob& job) {
  std::vector<ScanJob> one;
  one.push_back(std::move(job));
  std::vector<StageResult> results(1);
  processGroup(one, results);
  job = std::move(one.front());
  return results.front();
}

void JournalStage::processGroup(std::vector<ScanJob>& jobs, std::vector<StageResult>& results) {
  results.assign(jobs.size(), StageResult{});
  std::vector<std::size_t> appended;  // scans and commands written in this group
  auto refuse = [&](std::size_t i, const std::string& why) {
    ++failures_;
    {
      std::lock_guard lock(error_mutex_);
      last_error_ = why;
    }
    if (jobs[i].change) {
      jobs[i].change->result.status = Status::kFailed;
      jobs[i].change->result.message = why;
    } else {
      results[i] = StageResult::reject(why);
    }
  };
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    ScanJob& job = jobs[i];
    if (writer_->poisoned()) {  // checked first: after a failed fsync the journal's set is not durable
      refuse(i, fmt::format("not durable: {}", writer_->lastError()));
      continue;
    }
    try {
      if (job.change) {
        MapChange& c = *job.change;
        if (std::holds_alternative<SnapshotCommand>(c.command)) {
          // Everything before the snapshot ends in the old segment, so the snapshot can remove it.
          writer_->rotate();
          c.snapshot_lsn = writer_->lastLsn();
          c.snapshot_progress = journaled_.encode();
          scans_since_snapshot_ = 0;
        } else if (changesMap(c.command) && c.result.status == Status::kOk) {
          writer_->append(commandRecordKind(c.command), encodeCommandRecord(c.command, c.loaded_file));
          appended.push_back(i);
        }
        continue;
      }
      if (journaled_.contains(job.robot_id, job.seq)) {
        ++duplicates_;
        results[i] = StageResult::alreadyInMap(
            fmt::format("scan {}#{} is in the map already (a resend): durable, not applied again",
                        job.robot_id, job.seq));
        continue;
      }
      writer_->append(RecordKind::kScan, encodeScanRecord(job));
      journaled_.record(job.robot_id, job.seq);
      appended.push_back(i);
    } catch (const StorageError& e) {
      refuse(i, fmt::format("not durable, so not applied: {}", e.what()));
    }
  }
  if (appended.empty()) return;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    writer_->sync();
  } catch (const StorageError& e) {
    spdlog::error("journal: {}", e.what());
    for (std::size_t i = 0; i < jobs.size(); ++i) {
      if (jobs[i].change || results[i].ok || results[i].duplicate)
        refuse(i, std::string("not durable: ") + e.what());
    }
    return;
  }
  sync_ms_.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  std::lock_guard lock(durable_mutex_);
  for (std::size_t i : appended) {
    if (jobs[i].change) continue;
    jobs[i].durable = true;
    durable_.record(jobs[i].robot_id, jobs[i].seq);
    ++scans_since_snapshot_;
  }
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    if (results[i].duplicate) jobs[i].durable = true;
  }
}

std::optional<std::uint64_t> JournalStage::lastDurableSeq(const std::string& robot) const {
  std::lock_guard lock(durable_mutex_);
  return durable_.lastSeq(robot);
}

RobotProgress JournalStage::durableProgress() const {
  std::lock_guard lock(durable_mutex_);
  return durable_;
}

JournalCounters JournalStage::counters() const {
  JournalCounters c;
  c.bytes = writer_->bytesAppended();
  c.syncs = writer_->syncs();
  c.records = writer_->recordsAppended();
  c.last_lsn = writer_->lastLsn();
  c.duplicates = duplicates_;
  c.failures = failures_;
  c.scans_since_snapshot = scans_since_snapshot_;
  c.failed = writer_->poisoned();
  {
    std::lock_guard lock(error_mutex_);
    c.last_error = last_error_;
  }
  c.sync_ms = sync_ms_.summary();
  return c;
}

}  // namespace densemap::server::durability
