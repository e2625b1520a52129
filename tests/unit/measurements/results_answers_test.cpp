// The kept answers of GET …/results (server/measurements/results_answers.h): an answer is found
// only under the basis it was made from, the bound empties the store, an answer too large is not
// kept. Through the service, with two instances on one SQLite database: a tolerance table or a
// result that the other instance adds is in the very next answer, never a kept one.
#include "server/measurements/results_answers.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "analysis/core/errors.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::shared_ptr<const std::string> Text(std::size_t n, char c = 'x') {
  return std::make_shared<const std::string>(n, c);
}

TEST(ResultsAnswers, AnAnswerIsFoundOnlyUnderItsBasis) {
  ResultsAnswers answers;
  const MeasurementId id(7);
  const AnswerBasis basis{{3, 41}, 2};
  EXPECT_EQ(answers.Find(id, basis), nullptr);
  const auto a = Text(100);
  answers.Keep(id, basis, a);
  EXPECT_EQ(answers.Find(id, basis), a);
  EXPECT_EQ(answers.Find(MeasurementId(8), basis), nullptr);
  EXPECT_EQ(answers.Find(id, AnswerBasis{{4, 41}, 2}), nullptr);  // one result more
  EXPECT_EQ(answers.Find(id, AnswerBasis{{3, 42}, 2}), nullptr);  // another newest result
  EXPECT_EQ(answers.Find(id, AnswerBasis{{3, 41}, 3}), nullptr);  // a newer table
  // Replaced under a newer basis: the older one is gone, the bytes count the new answer.
  const auto b = Text(50);
  answers.Keep(id, AnswerBasis{{4, 45}, 2}, b);
  EXPECT_EQ(answers.Find(id, basis), nullptr);
  EXPECT_EQ(answers.Find(id, AnswerBasis{{4, 45}, 2}), b);
  EXPECT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers.bytes(), 50u + 256u);
}

TEST(ResultsAnswers, TheBoundEmptiesTheStoreAndALargeAnswerIsNotKept) {
  ResultsAnswers answers(16 * 1024);  // answers up to 1 KiB are kept
  for (int i = 1; i <= 13; ++i) answers.Keep(MeasurementId(i), {}, Text(1000));
  EXPECT_EQ(answers.size(), 13u);  // 13 × 1 256 bytes
  answers.Keep(MeasurementId(14), {}, Text(1000));
  EXPECT_EQ(answers.size(), 1u);  // the 14th does not fit: emptied, then kept
  EXPECT_NE(answers.Find(MeasurementId(14), {}), nullptr);
  EXPECT_EQ(answers.Find(MeasurementId(1), {}), nullptr);
  answers.Keep(MeasurementId(15), {}, Text(1025));
  EXPECT_EQ(answers.Find(MeasurementId(15), {}), nullptr);
  EXPECT_EQ(answers.bytes(), 1000u + 256u);
}

std::string ExampleFile(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class TwoInstances : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("km-answers-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    a_ = Open();
    b_ = Open();
  }
  void TearDown() override {
    a_.reset();
    b_.reset();
    fs::remove_all(dir_);
  }
  std::unique_ptr<Service> Open() const {
    auto svc = std::make_unique<Service>(std::make_unique<SqliteStorage>((dir_ / "km.db").string()),
                                         ServiceOptions{});
    RegisterBuiltinKinds(svc->measurements());
    return svc;
  }
  json Answer(MeasurementId id) const { return json::parse(*a_->measurements().ResultsAnswer(id)); }
  fs::path dir_;
  std::unique_ptr<Service> a_, b_;
};

TEST_F(TwoInstances, WhatTheOtherInstanceAddsIsInTheNextAnswer) {
  const auto up = a_->measurements().Upload(ExampleFile("dbb_xy-r150_ccw.txt"), "ccw.txt");
  auto& m = a_->measurements();
  const auto first = m.ResultsAnswer(up.id);
  EXPECT_EQ(*first, m.ResultsWithConformance(up.id).dump());
  EXPECT_EQ(m.ResultsAnswer(up.id), first);  // kept: the same answer, not made again
  EXPECT_EQ(json::parse(*first)["conformance"]["verdict"], "no tolerance");
  const double g = json::parse(*first)["iso230_4"]["circular_deviation_um"].get<double>();

  // A table put through the other instance judges the next answer of this one.
  json entry = {{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", g - 0.5}};
  b_->tolerances().Put("vmc-3axis", {{"tolerances", json::array({entry})}});
  EXPECT_EQ(Answer(up.id)["conformance"]["verdict"], "fail");
  EXPECT_EQ(Answer(up.id)["conformance"]["tolerance_version"], 1);
  entry["tolerance"] = g + 0.5;
  b_->tolerances().Put("vmc-3axis", {{"tolerances", json::array({entry})}});
  EXPECT_EQ(Answer(up.id)["conformance"]["verdict"], "pass");
  EXPECT_EQ(Answer(up.id)["conformance"]["tolerance_version"], 2);

  // A newer analysis version stored by the other instance is the next answer.
  json newer = json::parse(*first);
  newer.erase("conformance");
  newer["analysis_version"] = "dbb/99";
  b_->storage().PutResult(up.id, {"dbb", "dbb/99", newer.dump()});
  EXPECT_EQ(Answer(up.id)["analysis_version"], "dbb/99");
  EXPECT_EQ(Answer(up.id)["conformance"]["verdict"], "pass");
}

TEST_F(TwoInstances, TheRefusalsAreKept) {
  EXPECT_THROW(a_->measurements().ResultsAnswer(MeasurementId(12345)), NotFound);
}

}  // namespace
}  // namespace km::server
