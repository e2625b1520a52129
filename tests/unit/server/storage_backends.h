// The fixture of the tests run on both storage backends: Open() gives the test's database on
// the backend of the parameter ("sqlite": a file; "postgresql": a fresh database on the test
// server of tests/unit/server/pg_test_server.h), a second Open() the same database again (a
// reopen, or a second instance).
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "server/storage/storage.h"

namespace km::server::test {

class Backends : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override;
  void TearDown() override;
  std::unique_ptr<Storage> Open();
  bool postgres() const { return GetParam() == "postgresql"; }

  // A small measurement; measured_at 2026-01-0N with N = 1 + sha[0] % 8.
  static NewMeasurement Sample(const std::string& sha, const std::string& machine);
  static NewMachineModel Model(const std::string& machine, const std::string& doc);

  std::string path_;  // SQLite
  std::string url_;   // PostgreSQL
};

}  // namespace km::server::test
