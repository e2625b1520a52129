// The study requests parsed where they enter (server/jobs/study_requests.h): each field's type
// and range, errors naming the field, and the JSON a queued job keeps read back to the same
// request.
#include "server/jobs/study_requests.h"

#include <gtest/gtest.h>

#include "analysis/core/errors.h"
#include "tests/unit/expect_error.h"

namespace km::server {
namespace {

using nlohmann::json;
using test::Expect;

std::string FieldOfCalibration(const json& body) {
  return Expect<InvalidInput>([&] { CalibrationRequest::Parse(body); }).field();
}

std::string FieldOfDiscovery(const json& body) {
  return Expect<InvalidInput>([&] { DiscoveryRequest::Parse(body); }).field();
}

TEST(CalibrationRequest, EveryFieldIsReadIntoItsType) {
  const auto r = CalibrationRequest::Parse({{"machine_id", "pm600"},
                                            {"machine_version", 3},
                                            {"measurement_ids", {7, 4, 9}},
                                            {"method", "centre_corrected"},
                                            {"reduction_study_min_tests", 2},
                                            {"max_samples_per_test", 500},
                                            {"effects", {"gravity_deflection"}}});
  ASSERT_TRUE(r.model.has_value());
  EXPECT_EQ(r.model->machine_id, "pm600");
  EXPECT_EQ(r.model->version, 3);
  EXPECT_FALSE(r.machine.has_value());
  EXPECT_EQ(r.measurement_ids, (std::vector<std::int64_t>{7, 4, 9}));
  EXPECT_EQ(r.method, hexapod::CalibrationMethod::kCentreCorrected);
  EXPECT_EQ(r.reduction_study_min_tests, 2);
  EXPECT_EQ(r.max_samples_per_test, 500);
  EXPECT_EQ(r.effects, (std::vector<std::string>{"gravity_deflection"}));
}

TEST(CalibrationRequest, TheJobsPlanReadsBackToTheSameRequest) {
  const json body = {{"machine", {{"machine_id", "m"}, {"kind", "hexapod"}}},
                     {"measurement_ids", {12, 3}},
                     {"method", "absolute"},
                     {"max_samples_per_test", 0}};
  const auto r = CalibrationRequest::Parse(body);
  const json kept = r.ToJson();
  EXPECT_EQ(kept, body) << kept.dump();
  const auto again = CalibrationRequest::Parse(kept);
  EXPECT_EQ(again.ToJson(), kept);
  // Fields not given stay absent, so a job shows what its submitter asked for.
  EXPECT_FALSE(kept.contains("reduction_study_min_tests"));
  EXPECT_FALSE(kept.contains("effects"));
  // The documented spelling of the method, whichever the request used.
  EXPECT_EQ(CalibrationRequest::Parse(
                {{"machine_id", "m"}, {"measurement_ids", {1}}, {"method", "centre_corrected"}})
                .ToJson()["method"],
            "centre-corrected");
}

TEST(CalibrationRequest, BadFieldsAreNamed) {
  const json ids = {1, 2};
  EXPECT_EQ(FieldOfCalibration(json::array()), "");
  EXPECT_EQ(FieldOfCalibration({{"measurement_ids", ids}}), "machine");
  EXPECT_EQ(FieldOfCalibration({{"machine", "pm600"}, {"measurement_ids", ids}}), "machine");
  EXPECT_EQ(FieldOfCalibration(
                {{"machine", json::object()}, {"machine_id", "pm600"}, {"measurement_ids", ids}}),
            "machine_id");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", ""}, {"measurement_ids", ids}}), "machine_id");
  EXPECT_EQ(
      FieldOfCalibration({{"machine_id", "m"}, {"machine_version", 0}, {"measurement_ids", ids}}),
      "machine_version");
  EXPECT_EQ(
      FieldOfCalibration({{"machine_id", "m"}, {"method", "radial"}, {"measurement_ids", ids}}),
      "method");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}, {"method", 1}, {"measurement_ids", ids}}),
            "method");
  EXPECT_EQ(
      FieldOfCalibration(
          {{"machine_id", "m"}, {"reduction_study_min_tests", 1001}, {"measurement_ids", ids}}),
      "reduction_study_min_tests");
  EXPECT_EQ(FieldOfCalibration(
                {{"machine_id", "m"}, {"max_samples_per_test", -1}, {"measurement_ids", ids}}),
            "max_samples_per_test");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"},
                                {"effects", {"gravity_deflection", "gravity_deflection"}},
                                {"measurement_ids", ids}}),
            "effects");
  EXPECT_EQ(FieldOfCalibration(
                {{"machine_id", "m"}, {"effects", {"no_such_effect"}}, {"measurement_ids", ids}}),
            "effects");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}}), "measurement_ids");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}, {"measurement_ids", json::array()}}),
            "measurement_ids");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}, {"measurement_ids", {1, 0}}}),
            "measurement_ids");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}, {"measurement_ids", {1, 2.5}}}),
            "measurement_ids");
  EXPECT_EQ(FieldOfCalibration({{"machine_id", "m"}, {"measurement_ids", {1, "2"}}}),
            "measurement_ids");
  EXPECT_EQ(
      FieldOfCalibration({{"machine_id", "m"}, {"measurement_ids", {1, 18446744073709551615ull}}}),
      "measurement_ids");
}

TEST(CalibrationRequest, AnUnknownMethodIsNamedAsAFieldOfTheRequest) {
  const auto e = Expect<InvalidInput>([] {
    CalibrationRequest::Parse(
        {{"machine_id", "m"}, {"method", "radial"}, {"measurement_ids", {1}}});
  });
  EXPECT_EQ(e.file(), "request");
  EXPECT_EQ(e.field(), "method");
  EXPECT_TRUE(test::Contains(e.what(), "'radial' is neither absolute nor centre-corrected"))
      << e.what();
}

TEST(DiscoveryRequest, ReadsAStoredModelOrNone) {
  const auto serial = DiscoveryRequest::Parse({{"measurement_ids", {2, 1}}});
  EXPECT_FALSE(serial.model.has_value());
  EXPECT_EQ(serial.ToJson(), (json{{"measurement_ids", {2, 1}}}));
  const json body = {{"machine_id", "pm600"},
                     {"machine_version", 2},
                     {"measurement_ids", {8}},
                     {"max_samples_per_test", 90}};
  const auto stored = DiscoveryRequest::Parse(body);
  ASSERT_TRUE(stored.model.has_value());
  EXPECT_EQ(stored.model->version, 2);
  EXPECT_EQ(stored.ToJson(), body);
}

TEST(DiscoveryRequest, BadFieldsAreNamed) {
  EXPECT_EQ(FieldOfDiscovery("text"), "");
  EXPECT_EQ(FieldOfDiscovery({{"machine", json::object()}, {"measurement_ids", {1}}}), "machine");
  EXPECT_EQ(FieldOfDiscovery({{"machine_version", 2}, {"measurement_ids", {1}}}),
            "machine_version");
  EXPECT_EQ(FieldOfDiscovery({{"machine_id", 7}, {"measurement_ids", {1}}}), "machine_id");
  EXPECT_EQ(FieldOfDiscovery({{"max_samples_per_test", 1e9}, {"measurement_ids", {1}}}),
            "max_samples_per_test");
  EXPECT_EQ(FieldOfDiscovery({{"measurement_ids", {-3}}}), "measurement_ids");
}

}  // namespace
}  // namespace km::server
