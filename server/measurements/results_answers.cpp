#include "server/measurements/results_answers.h"

namespace km::server {
namespace {
// What an entry costs beside its text (the map's node, the shared string), counted in the bound.
constexpr std::size_t kEntryBytes = 256;
std::size_t Charge(const std::string& answer) {
  return answer.size() + kEntryBytes;
}
}  // namespace

std::shared_ptr<const std::string> ResultsAnswers::Find(MeasurementId id,
                                                        const AnswerBasis& basis) const {
  std::lock_guard lock(mu_);
  const auto it = answers_.find(id);
  if (it == answers_.end() || !(it->second.basis == basis)) return nullptr;
  return it->second.answer;
}

void ResultsAnswers::Keep(MeasurementId id, const AnswerBasis& basis,
                          std::shared_ptr<const std::string> answer) {
  if (!answer || answer->size() > max_bytes_ / 16) return;
  std::lock_guard lock(mu_);
  if (const auto it = answers_.find(id); it != answers_.end()) {
    bytes_ -= Charge(*it->second.answer);
    answers_.erase(it);
  }
  if (bytes_ + Charge(*answer) > max_bytes_) {
    answers_.clear();
    bytes_ = 0;
  }
  bytes_ += Charge(*answer);
  answers_.emplace(id, Entry{basis, std::move(answer)});
}

std::size_t ResultsAnswers::size() const {
  std::lock_guard lock(mu_);
  return answers_.size();
}

std::size_t ResultsAnswers::bytes() const {
  std::lock_guard lock(mu_);
  return bytes_;
}

}  // namespace km::server
