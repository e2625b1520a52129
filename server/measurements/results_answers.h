// The serialised answers of GET /api/v1/measurements/{id}/results, the query the dashboards
// repeat most. An answer is kept with what it was made from: the stamp of the measurement's
// stored results and the version of its machine's tolerance table. Both are read from storage
// on every request (one query of indexes, no document text), so a kept answer is served only
// while it is still the answer, whichever instance on the same database added a result or a
// table. Bounded by the bytes it holds (emptied when full); an answer larger than a sixteenth of
// the bound is made and not kept.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "server/storage/storage.h"

namespace km::server {

class ResultsAnswers {
 public:
  explicit ResultsAnswers(std::size_t max_bytes = 32u << 20) : max_bytes_(max_bytes) {}
  ResultsAnswers(const ResultsAnswers&) = delete;
  ResultsAnswers& operator=(const ResultsAnswers&) = delete;

  // The answer kept for the measurement when it was made from `basis`; null otherwise.
  std::shared_ptr<const std::string> Find(MeasurementId id, const AnswerBasis& basis) const;
  // Keeps (or replaces) the measurement's answer, made from `basis`.
  void Keep(MeasurementId id, const AnswerBasis& basis, std::shared_ptr<const std::string> answer);

  std::size_t size() const;
  std::size_t bytes() const;  // the answers' bytes, and 256 for each entry

 private:
  struct Entry {
    AnswerBasis basis;
    std::shared_ptr<const std::string> answer;
  };
  std::size_t max_bytes_;
  mutable std::mutex mu_;
  std::unordered_map<MeasurementId, Entry> answers_;
  std::size_t bytes_ = 0;
};

}  // namespace km::server
