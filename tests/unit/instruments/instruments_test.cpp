// The instrument register's pure parts (server/instruments/instruments.h) and the instrument
// header keys of every kind of file (ingest/text_format.h): a body is refused naming the field
// of anything wrong; every parser accepts the instrument keys and unknown keys and hands them on
// in `metadata`, and refuses a bad u_* value, serial, calibration date or certificate naming
// file, line and key; completing a file from an entry copies exactly what the file does not
// state, names the source of every u_* key and finds an overdue calibration.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/form_parsers.h"
#include "ingest/positioning_parser.h"
#include "ingest/servo_parser.h"
#include "ingest/text_format.h"
#include "ingest/tracker_parser.h"
#include "server/instruments/instruments.h"
#include "tests/unit/expect_error.h"

namespace km::server {
namespace {

using nlohmann::json;

// An example file without its own `instrument` line (the positioning example names its laser).
std::string Example(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::string out, line;
  while (std::getline(in, line)) {
    if (line.rfind("# instrument:", 0) != 0) out += line + "\n";
  }
  return out;
}

// The file with `lines` inserted after its format line (line 1).
std::string WithHeader(const std::string& file, const std::string& lines) {
  const auto nl = file.find('\n');
  return file.substr(0, nl + 1) + lines + file.substr(nl + 1);
}

json Body() {
  return {{"instrument", "Renishaw QC20-W"},
          {"kind", "ballbar"},
          {"uncertainties", {{"u_reading_um", 0.5}, {"u_bar_length_um", 0.7}}},
          {"calibrated", "2025-03-01"},
          {"calibration_interval_days", 365},
          {"certificate", "UKAS 0123 / 2025-117"}};
}

std::string RefusedField(const json& body) {
  return test::Expect<InvalidInput>([&] { ParseInstrumentBody(body); }).field();
}

TEST(InstrumentBody, AGoodBodyReadsBackAsItWasGiven) {
  const Instrument i = ParseInstrumentBody(Body());
  EXPECT_EQ(i.instrument, "Renishaw QC20-W");
  EXPECT_EQ(i.kind, "ballbar");
  EXPECT_EQ(i.uncertainties.at("u_reading_um"), 0.5);
  EXPECT_EQ(*i.calibrated, "2025-03-01");
  EXPECT_EQ(*i.calibration_interval_days, 365);
  EXPECT_EQ(*CalibrationDue(i), "2026-03-01");
  EXPECT_EQ(ParseInstrumentBody(InstrumentBodyJson(i)).uncertainties, i.uncertainties);
  // Only instrument and kind are required; the optional ones may be null.
  const Instrument bare = ParseInstrumentBody({{"instrument", "level"},
                                               {"kind", "level"},
                                               {"calibrated", nullptr},
                                               {"certificate", nullptr}});
  EXPECT_FALSE(bare.calibrated);
  EXPECT_FALSE(CalibrationDue(bare));
  EXPECT_TRUE(InstrumentBodyJson(bare)["calibration_interval_days"].is_null());
}

TEST(InstrumentBody, EachMistakeIsRefusedNamingItsField) {
  EXPECT_EQ(RefusedField(json::array()), "body");
  EXPECT_EQ(RefusedField("text"), "body");
  const auto with = [](const std::string& key, const json& v) {
    json b = Body();
    b[key] = v;
    return b;
  };
  const auto without = [](const std::string& key) {
    json b = Body();
    b.erase(key);
    return b;
  };
  EXPECT_EQ(RefusedField(with("colour", "red")), "colour");
  EXPECT_EQ(RefusedField(without("instrument")), "instrument");
  EXPECT_EQ(RefusedField(without("kind")), "kind");
  EXPECT_EQ(RefusedField(with("instrument", "")), "instrument");
  EXPECT_EQ(RefusedField(with("instrument", 7)), "instrument");
  EXPECT_EQ(RefusedField(with("instrument", "two\nlines")), "instrument");
  EXPECT_EQ(RefusedField(with("instrument", "bidi \u202e text")), "instrument");
  EXPECT_EQ(RefusedField(with("instrument", std::string(257, 'x'))), "instrument");
  EXPECT_EQ(RefusedField(with("kind", "caliper")), "kind");
  EXPECT_EQ(RefusedField(with("uncertainties", json::array())), "uncertainties");
  EXPECT_EQ(RefusedField(with("uncertainties", {{"u_colour", 1}})), "uncertainties.u_colour");
  EXPECT_EQ(RefusedField(with("uncertainties", {{"u_laser_ppm", -0.1}})),
            "uncertainties.u_laser_ppm");
  EXPECT_EQ(RefusedField(with("uncertainties", {{"u_laser_ppm", "0.1"}})),
            "uncertainties.u_laser_ppm");
  EXPECT_EQ(RefusedField(with("uncertainties", {{"u_laser_ppm", 1e300}})),
            "uncertainties.u_laser_ppm");
  EXPECT_EQ(RefusedField(with("uncertainties", {{"u_laser_ppm", nullptr}})),
            "uncertainties.u_laser_ppm");
  for (const char* bad : {"2025-02-29", "2025-13-01", "2025-3-1", "01.03.2025", "2025-03-01T00:00Z",
                          "1899-12-31", ""}) {
    EXPECT_EQ(RefusedField(with("calibrated", bad)), "calibrated") << bad;
  }
  EXPECT_EQ(RefusedField(with("calibrated", 20250301)), "calibrated");
  for (const json& bad :
       {json(0), json(3661), json(-5), json(30.5), json("30"), json(18446744073709551615ull)}) {
    EXPECT_EQ(RefusedField(with("calibration_interval_days", bad)), "calibration_interval_days")
        << bad.dump();
  }
  EXPECT_EQ(RefusedField(with("certificate", std::string(300, 'c'))), "certificate");
  EXPECT_EQ(RefusedField(with("certificate", "a\rb")), "certificate");
  // A leap day is a day.
  EXPECT_NO_THROW(ParseInstrumentBody(with("calibrated", "2024-02-29")));
}

TEST(InstrumentSerial, OnlyCharactersThatMeanNothingAnywhere) {
  for (const char* good : {"XL80-12345", "QC20W.7", "A", "sn:42_b", "9ABC"}) {
    EXPECT_FALSE(ingest::InstrumentSerialProblem(good)) << good;
  }
  for (const std::string& bad :
       {std::string(""), std::string("../etc"), std::string(".."), std::string("a/b"),
        std::string("a\\b"), std::string("a\r\nb"), std::string("\"q\""), std::string("<b>"),
        std::string("=SUM(A1)"), std::string("-1"), std::string("a b"), std::string("a,b"),
        std::string("a;b"), std::string("é"), std::string(65, 'x'), std::string("a\0b", 3)}) {
    EXPECT_TRUE(ingest::InstrumentSerialProblem(bad)) << bad;
  }
}

TEST(IsoDates, DaysRoundTripAndOnlyRealDaysAreRead) {
  EXPECT_EQ(*ingest::IsoDateDays("1970-01-01"), 0);
  EXPECT_EQ(*ingest::IsoDateDays("2000-03-01"), 11017);
  EXPECT_EQ(ingest::IsoDateFromDays(*ingest::IsoDateDays("2024-02-29") + 366), "2025-03-01");
  for (std::int64_t d = -25567; d < 2900000; d += 997) {  // 1900 … 9909
    EXPECT_EQ(*ingest::IsoDateDays(ingest::IsoDateFromDays(d)), d);
  }
  EXPECT_FALSE(ingest::IsoDateDays("2023-02-29"));
  EXPECT_FALSE(ingest::IsoDateDays("1900-02-29"));
  EXPECT_TRUE(ingest::IsoDateDays("2000-02-29"));
  EXPECT_FALSE(ingest::IsoDateDays("2025-04-31"));
  EXPECT_FALSE(ingest::IsoDateDays("2025-00-10"));
  EXPECT_FALSE(ingest::IsoDateDays("+025-01-10"));
}

const char* const kInstrumentKeys =
    "# instrument: Renishaw XL-80 laser\n"
    "# instrument_serial: XL80-0815\n"
    "# instrument_calibrated: 2025-06-30\n"
    "# instrument_certificate: DAkkS D-K-15070 / 4711\n"
    "# u_reading_um: 0.25\n"
    "# colour_of_the_tripod: blue\n";

// The metadata of each kind of file parsed with the instrument keys and an unknown key added.
std::map<std::string, std::map<std::string, std::string>> MetadataOfEveryKind() {
  const std::string k = kInstrumentKeys;
  return {
      {"dbb", ingest::ParseDbb(WithHeader(Example("dbb_xy-r150_cw.txt"), k), "d").metadata},
      {"straightness",
       ingest::ParseStraightnessFile(WithHeader(Example("straightness_x-z.txt"), k), "s").metadata},
      {"flatness",
       ingest::ParseFlatnessFile(WithHeader(Example("flatness_table.txt"), k), "f").metadata},
      {"parallelism",
       ingest::ParseParallelismFile(WithHeader(Example("parallelism_x_t-slot.txt"), k), "p")
           .metadata},
      {"tracker",
       ingest::ParseTrackerFile(WithHeader(Example("tracker_cube.txt"), k), "t").metadata},
      {"positioning",
       ingest::ParsePositioningFile(WithHeader(Example("positioning_x.txt"), k), "x").metadata},
      {"servo",
       ingest::ParseServoFile(WithHeader(Example("servo_x-strokes.txt"), k), "v").metadata},
  };
}

TEST(InstrumentHeaderKeys, EveryKindTakesThemAndUnknownKeysIntoItsMetadata) {
  const auto all = MetadataOfEveryKind();
  EXPECT_EQ(all.size(), 7u);
  for (const auto& [kind, m] : all) {
    EXPECT_EQ(m.at("instrument"), "Renishaw XL-80 laser") << kind;
    EXPECT_EQ(m.at("instrument_serial"), "XL80-0815") << kind;
    EXPECT_EQ(m.at("instrument_calibrated"), "2025-06-30") << kind;
    EXPECT_EQ(m.at("instrument_certificate"), "DAkkS D-K-15070 / 4711") << kind;
    EXPECT_EQ(m.at("u_reading_um"), "0.25") << kind;
    EXPECT_EQ(m.at("colour_of_the_tripod"), "blue") << kind;
  }
}

TEST(InstrumentHeaderKeys, ABadValueIsRefusedNamingFileLineAndKey) {
  const std::string dbb = Example("dbb_xy-r150_cw.txt");
  const std::string straightness = Example("straightness_x-z.txt");
  struct Case {
    std::string line, key;
  };
  const Case cases[] = {
      {"# u_reading_um: -0.1", "u_reading_um"},
      {"# u_reading_um: nan", "u_reading_um"},
      {"# u_reading_um: inf", "u_reading_um"},
      {"# u_reading_um: 1e400", "u_reading_um"},
      {"# u_reading_um: 2e6", "u_reading_um"},
      {"# u_reading_um: 0.1 um", "u_reading_um"},
      {"# u_anything_new: x", "u_anything_new"},
      {"# instrument_serial: ../../etc/passwd", "instrument_serial"},
      {"# instrument_serial: =HYPERLINK(\"x\")", "instrument_serial"},
      {"# instrument_serial: <script>", "instrument_serial"},
      {"# instrument_serial: " + std::string(65, 'S'), "instrument_serial"},
      {"# instrument_calibrated: 2025-02-30", "instrument_calibrated"},
      {"# instrument_calibrated: yesterday", "instrument_calibrated"},
      {"# instrument_certificate: " + std::string(257, 'c'), "instrument_certificate"},
      {"# instrument: " + std::string(300, 'i'), "instrument"},
  };
  for (const auto& c : cases) {
    const std::vector<std::pair<std::string, std::string>> files = {{"dbb.txt", dbb},
                                                                    {"line.txt", straightness}};
    for (const auto& [name, file] : files) {
      const auto e = test::Expect<InvalidInput>([&, n = std::string(name), f = file] {
        if (n == "dbb.txt") {
          ingest::ParseDbb(WithHeader(f, c.line + "\n"), n);
        } else {
          ingest::ParseStraightnessFile(WithHeader(f, c.line + "\n"), n);
        }
      });
      EXPECT_EQ(e.file(), name) << c.line;
      EXPECT_EQ(e.line(), 2u) << c.line;
      EXPECT_EQ(e.field(), c.key) << c.line;
    }
  }
  // Zero and plain numbers are uncertainties; after the column header a '#' line is a marker.
  EXPECT_NO_THROW(ingest::ParseDbb(WithHeader(dbb, "# u_reading_um: 0\n# u_x: 1.5e-3\n"), "d"));
}

Instrument Registered() {
  Instrument i = ParseInstrumentBody(Body());
  i.serial = "QC20-7";
  i.version = 3;
  return i;
}

double Epoch(const std::string& day) {
  return static_cast<double>(*ingest::IsoDateDays(day)) * 86400.0;
}

TEST(ApplyInstrument, AFileWithoutInstrumentKeysGetsNothing) {
  std::map<std::string, std::string> m = {{"u_reading_um", "0.1"}, {"machine_id", "m"}};
  const auto before = m;
  const auto use = ApplyInstrument(m, Registered(), std::nullopt, Epoch("2025-05-01"));
  EXPECT_TRUE(use.block.is_null());
  EXPECT_TRUE(use.warnings.empty());
  EXPECT_EQ(m, before);
}

TEST(ApplyInstrument, TheRegisterFillsWhatTheFileDoesNotState) {
  std::map<std::string, std::string> m = {
      {"instrument_serial", "QC20-7"}, {"u_reading_um", "0.25"}, {"u_spindle_um", "1"}};
  const auto use = ApplyInstrument(m, Registered(), "2025-06-01T10:00:00Z", Epoch("2030-01-01"));
  EXPECT_EQ(m.at("u_reading_um"), "0.25");  // the file's own
  EXPECT_EQ(m.at("u_bar_length_um"), "0.7");
  EXPECT_EQ(m.at("instrument"), "Renishaw QC20-W");
  EXPECT_EQ(m.at("instrument_calibrated"), "2025-03-01");
  EXPECT_EQ(m.at("instrument_certificate"), "UKAS 0123 / 2025-117");
  const json& b = use.block;
  EXPECT_EQ(b["instrument"], "Renishaw QC20-W");
  EXPECT_EQ(b["serial"], "QC20-7");
  EXPECT_EQ(b["calibrated"], "2025-03-01");
  EXPECT_EQ(b["certificate"], "UKAS 0123 / 2025-117");
  EXPECT_EQ(b["register_version"], 3);
  EXPECT_FALSE(b["kind"].is_null());  // the register's kind of instrument
  EXPECT_EQ(
      b["sources"],
      json({{"u_reading_um", "file"}, {"u_bar_length_um", "register"}, {"u_spindle_um", "file"}}));
  EXPECT_EQ(b["calibration_due"], "2026-03-01");
  EXPECT_EQ(b["overdue"], false);  // measured in 2025, uploaded long after
  EXPECT_TRUE(use.warnings.empty());
}

TEST(ApplyInstrument, AMeasurementAfterTheDueDayIsOverdueWithAWarning) {
  const auto overdue = [](const std::optional<std::string>& when, double upload) {
    std::map<std::string, std::string> m = {{"instrument_serial", "QC20-7"}};
    return ApplyInstrument(m, Registered(), when, upload);
  };
  EXPECT_EQ(overdue("2026-03-01T23:59:59Z", 0).block["overdue"], false);  // on the due day
  const auto late = overdue("2026-03-02T00:00:00Z", 0);
  EXPECT_EQ(late.block["overdue"], true);
  ASSERT_EQ(late.warnings.size(), 1u);
  EXPECT_EQ(late.warnings[0],
            "instrument QC20-7 was past its calibration interval (due 2026-03-01) when this was "
            "measured");
  // Without a time in the file: the upload time.
  EXPECT_EQ(overdue(std::nullopt, Epoch("2026-03-05")).block["overdue"], true);
  EXPECT_EQ(overdue(std::nullopt, Epoch("2026-02-05")).block["overdue"], false);
  // The file's own calibration date comes before the register's.
  std::map<std::string, std::string> m = {{"instrument_serial", "QC20-7"},
                                          {"instrument_calibrated", "2026-02-20"}};
  const auto recal = ApplyInstrument(m, Registered(), "2026-06-01", 0);
  EXPECT_EQ(recal.block["calibration_due"], "2027-02-20");
  EXPECT_EQ(recal.block["overdue"], false);
}

TEST(ApplyInstrument, AnUnregisteredSerialGivesTheFileAlone) {
  std::map<std::string, std::string> m = {{"instrument_serial", "NEW-1"},
                                          {"instrument_calibrated", "2020-01-01"},
                                          {"u_reading_um", "0.3"}};
  const auto use = ApplyInstrument(m, std::nullopt, std::nullopt, Epoch("2026-01-01"));
  EXPECT_EQ(m.size(), 3u);
  EXPECT_EQ(use.block["serial"], "NEW-1");
  EXPECT_TRUE(use.block["instrument"].is_null());
  EXPECT_TRUE(use.block["register_version"].is_null());
  EXPECT_TRUE(use.block["calibration_due"].is_null());
  EXPECT_EQ(use.block["overdue"], false);
  EXPECT_EQ(use.block["sources"], json({{"u_reading_um", "file"}}));
}

}  // namespace
}  // namespace km::server
