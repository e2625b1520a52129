// Plot buckets over the widest time range there is: time stamps near both ends of int64 and a
// request from INT64_MIN + 1 to INT64_MAX must bucket without overflow (checked under UBSan).
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "server/storage/sqlite/sqlite_storage.h"
#include "server/streams/stream_chunks.h"
#include "server/streams/streams.h"
#include "tests/unit/server/temp_dir.h"
#include "usecases/stream_profile.h"

namespace km::server {
namespace {

constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();

class StreamExtremes : public test::TempDirTest {
 protected:
  // One channel whose samples are spread over (nearly) the whole int64 range.
  StreamId Store(SqliteStorage& st, const std::vector<std::int64_t>& t_us) {
    const auto id = st.CreateStream({"m1", "", "http", "{}"});
    ingest::SampleRun run;
    run.channel = 1;
    run.first_counter = 0;
    for (std::size_t i = 0; i < t_us.size(); ++i) {
      run.t_us.push_back(t_us[i]);
      run.value_um.push_back(static_cast<double>(i));
      run.status.push_back(0);
    }
    auto c = EncodeStreamChunk(run, 0, run.size());
    c.stream_id = id;
    st.AppendStream({c}, {});
    return id;
  }
};

TEST_F(StreamExtremes, BucketsSpanningTheWholeInt64Range) {
  SqliteStorage st(Path("s.db"));
  const std::vector<std::int64_t> t = {kMin + 1, kMin + 2, -1'000'000'000, -1,       0,
                                       1,        7,        kMax / 2,       kMax - 2, kMax - 1};
  const auto id = Store(st, t);
  for (const std::size_t buckets : {std::size_t{2}, std::size_t{3}, std::size_t{5}}) {
    SCOPED_TRACE(buckets);
    const auto j = StreamSamplesJson(st, id, 1, kMin + 1, kMax, buckets);
    ASSERT_TRUE(j["downsampled"].get<bool>()) << j.dump();
    EXPECT_EQ(j["samples_in_range"].get<std::int64_t>(), 10);
    std::int64_t total = 0, prev = kMin;
    double lowest = 1e300, highest = -1e300;
    for (std::size_t k = 0; k < j["t_us"].size(); ++k) {
      const auto tk = j["t_us"][k].get<std::int64_t>();
      EXPECT_GT(tk, prev) << "bucket times ascend";
      prev = tk;
      EXPECT_LE(j["min_um"][k].get<double>(), j["max_um"][k].get<double>());
      lowest = std::min(lowest, j["min_um"][k].get<double>());
      highest = std::max(highest, j["max_um"][k].get<double>());
      total += j["count"][k].get<std::int64_t>();
    }
    EXPECT_EQ(total, 10);
    EXPECT_EQ(lowest, 0.0);
    EXPECT_EQ(highest, 9.0);
    EXPECT_GT(j["bucket_us"].get<double>(), 1e18);
    // The first sample falls in the first bucket, the last in the last.
    EXPECT_EQ(j["min_um"][0].get<double>(), 0.0);
    EXPECT_EQ(j["max_um"][j["max_um"].size() - 1].get<double>(), 9.0);
  }
  // Both ends of the range from the stored samples themselves.
  const auto wide = StreamSamplesJson(st, id, 1, kMin, kMax, 4);
  EXPECT_EQ(wide["samples_in_range"].get<std::int64_t>(), 10);
  // Every sample, no buckets.
  const auto raw = StreamSamplesJson(st, id, 1, kMin + 1, kMax, 100);
  ASSERT_FALSE(raw["downsampled"].get<bool>());
  EXPECT_EQ(raw["t_us"].size(), 10u);
}

TEST_F(StreamExtremes, SamplesAtTheVeryEndsOfTheRange) {
  SqliteStorage st(Path("s.db"));
  const auto id = Store(st, {kMin, kMin + 1, 0, kMax - 1, kMax});
  // [INT64_MIN + 1, INT64_MAX) holds the three middle samples.
  const auto j = StreamSamplesJson(st, id, 1, kMin + 1, kMax, 2);
  ASSERT_TRUE(j["downsampled"].get<bool>()) << j.dump();
  EXPECT_EQ(j["samples_in_range"].get<std::int64_t>(), 3);
  std::int64_t total = 0;
  for (const auto& c : j["count"]) total += c.get<std::int64_t>();
  EXPECT_EQ(total, 3);
  for (const auto& tk : j["t_us"]) {
    EXPECT_GE(tk.get<std::int64_t>(), kMin + 1);
    EXPECT_LT(tk.get<std::int64_t>(), kMax);
  }
}

// Feed × time positions of samples at both ends of int64 (t − t_0 does not fit an int64).
TEST(StreamProfileExtremes, FeedPositionsAcrossTheWholeInt64Range) {
  const auto x = usecases::FeedPositionMm({kMax, 0, kMin, kMax - 5}, 1.0, 600.0);  // 1e-5 mm/µs
  ASSERT_EQ(x.size(), 4u);
  EXPECT_DOUBLE_EQ(x[0], 1.0);
  EXPECT_NEAR(x[1], 1.0 - 1e-5 * 9.223372036854775807e18, 1e-9 * 9.3e13);
  EXPECT_NEAR(x[2], 1.0 - 1e-5 * 1.8446744073709551615e19, 1e-9 * 1.9e14);
  EXPECT_NEAR(x[3], 1.0 - 5e-5, 1e-12);
  const auto y = usecases::FeedPositionMm({kMin, kMax}, 0.0, 600.0);
  EXPECT_NEAR(y[1], 1e-5 * 1.8446744073709551615e19, 1e-9 * 1.9e14);
}

}  // namespace
}  // namespace km::server
