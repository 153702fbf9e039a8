// Many logs, one identification each: per-file step and a small private thread
// pool (include/quadid/batch.hpp).
#include "quadid/batch.hpp"

#include "quadid/logs.hpp"

#include "quadid/io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <mutex>
#include <new>
#include <optional>
#include <stdexcept>
#include <thread>

namespace quadid {

FlightLog load_log_file(const std::string& path, const CsvReadOptions& csv) {
  // Every format quadid reads (CSV, ULog, Crazyflie uSD), recognised by its
  // first bytes: `quadid batch`, quadid.read_log, quadid.identify and the fleet runner.
  logs::LoadOptions load;
  load.csv = csv;
  return logs::load_any_log(path, load);
}

nlohmann::ordered_json identify_log_file(const std::string& path, const IdentifyRequest& req, Evolution* evolution,
                                         std::string* report) {
  const IdentificationInput in = prepare_identification(path, req);  // InputError names the file
  IdentificationResult res;
  try {
    res = identify_prepared(in);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path, e.what()));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}: {}", path, e.what()));
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("{}: {}", path, e.what()));
  }
  nlohmann::ordered_json j = to_json(res);
  j["log"] = path;
  add_input_json(j, in);
  if (report) *report = identification_report(in, res, j, path);
  if (evolution) *evolution = std::move(res.evolution);
  return j;
}

void BatchOptions::validate() const {
  if (threads < 0) throw std::invalid_argument(fmt::format("--threads {}: expected 0 (one per core) or more", threads));
}

nlohmann::ordered_json to_json(const BatchRecord& r) {
  if (!r.ok) return {{"path", r.path}, {"ok", false}, {"error", r.error}};
  nlohmann::ordered_json j = r.result;
  j["path"] = r.path;
  j["ok"] = true;
  return j;
}

BatchSummary identify_batch(const std::vector<std::string>& paths, const IdentifyRequest& req,
                            const BatchOptions& opt, const BatchSink& sink, const BatchProgress& progress) {
  opt.validate();
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const std::size_t n = paths.size();
  BatchSummary summary;
  summary.total = n;
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t want = opt.threads > 0 ? static_cast<std::size_t>(opt.threads) : hw;
  summary.threads = static_cast<int>(std::max<std::size_t>(1, std::min(want, n)));
  // With several logs at once the workers keep the cores busy: each log is
  // identified on its own worker's thread alone (the same results: the
  // threads never change what is computed), instead of two or three threads
  // per log fighting over the cores.
  IdentifyRequest per_log = req;
  if (summary.threads > 1) {
    per_log.options.processing.threads = 1;
    per_log.csv.threads = 1;
  }

  // Records finished out of order wait here until every earlier one is emitted.
  std::vector<std::optional<BatchRecord>> pending(n);
  std::size_t next_emit = 0, done = 0;
  std::mutex mu;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::exception_ptr callback_error;

  auto run_one = [&](std::size_t i) {
    BatchRecord rec;
    rec.path = paths[i];
    const auto s0 = Clock::now();
    try {
      rec.result = identify_log_file(paths[i], per_log, nullptr, opt.reports ? &rec.report : nullptr);
      rec.ok = true;
    } catch (const std::bad_alloc&) {
      rec.error = fmt::format("{}: out of memory", paths[i]);
    } catch (const std::exception& e) {
      rec.error = e.what();
    } catch (...) {
      rec.error = fmt::format("{}: unknown error", paths[i]);
    }
    rec.seconds = std::chrono::duration<double>(Clock::now() - s0).count();

    std::lock_guard lock(mu);
    if (stop) return;
    try {
      ++done;
      (rec.ok ? summary.ok : summary.failed)++;
      if (progress) progress(done, n, rec);
      pending[i] = std::move(rec);
      while (next_emit < n && pending[next_emit]) {
        if (sink) sink(next_emit, *pending[next_emit]);
        pending[next_emit].reset();
        ++next_emit;
      }
    } catch (...) {
      callback_error = std::current_exception();
      stop = true;
    }
  };
  auto worker = [&] {
    for (std::size_t i = next++; i < n && !stop; i = next++) run_one(i);
  };

  std::vector<std::thread> pool;
  for (int k = 1; k < summary.threads; ++k) pool.emplace_back(worker);
  worker();  // the calling thread is one of the workers
  for (auto& t : pool) t.join();
  if (callback_error) std::rethrow_exception(callback_error);
  summary.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return summary;
}

std::vector<std::string> parse_path_list(const std::string& text, const std::string& source) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  int line_no = 0;
  while (pos <= text.size()) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    std::string line = text.substr(pos, eol - pos);
    ++line_no;
    pos = eol + 1;
    const auto b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos) continue;
    const auto e = line.find_last_not_of(" \t\r");
    line = line.substr(b, e - b + 1);
    if (line.front() == '#') continue;
    if (line.find('\0') != std::string::npos)
      throw InputError(fmt::format("{}:{}: a path holds a NUL byte (is this a list of paths?)", source, line_no));
    out.push_back(std::move(line));
  }
  return out;
}

}  // namespace quadid
