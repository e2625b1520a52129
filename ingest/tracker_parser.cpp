#include "ingest/tracker_parser.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/text_format.h"

namespace km::ingest {

namespace {

// A strict integer from a number already parsed (the text reader gives doubles).
bool AsInt(double v, long long& out) {
  if (!std::isfinite(v) || std::abs(v) > 1e15 || std::floor(v) != v) return false;
  out = static_cast<long long>(v);
  return true;
}

// A reading column name: d<digits>_um.
bool IsReadingColumn(std::string_view name) {
  if (name.size() < 5 || name.front() != 'd' || name.substr(name.size() - 3) != "_um") {
    return false;
  }
  const auto digits = name.substr(1, name.size() - 4);
  return std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// The first row (in file order) whose point id repeats an earlier row's, and that earlier row;
// row = the number of rows when no id repeats. Ids are compared as read (equal numbers are equal
// integers).
struct Repeat {
  std::size_t row = 0;
  std::size_t first = 0;
};

// The `tracker_guess_mm: j, x, y, z` header lines: each tracker at most once, within 100 m.
std::vector<tracker::TrackerGuess> TrackerGuesses(const TextTable& t, const std::string& file,
                                                  long long n) {
  std::vector<tracker::TrackerGuess> guesses;
  std::set<long long> guessed;
  for (const HeaderValue* g : t.FindAll("tracker_guess_mm")) {
    const auto v = ParseNumberList(g->value);
    if (!v || v->size() != 4) {
      throw InvalidInput(file, g->line, "tracker_guess_mm",
                         "expected 'j, x, y, z' (tracker number and its position in mm)");
    }
    long long j = 0;
    if (!AsInt((*v)[0], j) || j < 1 || j > n) {
      throw InvalidInput(file, g->line, "tracker_guess_mm",
                         "tracker number must be an integer within 1.." + std::to_string(n));
    }
    if (!guessed.insert(j).second) {
      throw InvalidInput(file, g->line, "tracker_guess_mm",
                         "tracker " + std::to_string(j) + " is given twice");
    }
    tracker::TrackerGuess guess;
    guess.tracker = static_cast<int>(j - 1);
    guess.position_mm = {(*v)[1], (*v)[2], (*v)[3]};
    if (!guess.position_mm.allFinite() ||
        guess.position_mm.cwiseAbs().maxCoeff() > tracker::kMaxTrackerGuessMm) {
      throw InvalidInput(file, g->line, "tracker_guess_mm",
                         "tracker " + std::to_string(j) +
                             ": a guessed position farther than 100 m (1e5 mm) from the machine "
                             "origin is not a rough position of a tracker");
    }
    guesses.push_back(guess);
  }
  return guesses;
}

// Where the columns are: point, x_mm, y_mm, z_mm and d1_um … dn_um (no reading column of a
// tracker beyond n).
struct ReadingColumns {
  int point = -1, x = -1, y = -1, z = -1;
  std::vector<int> d;
};
ReadingColumns FindReadingColumns(const TextTable& t, const std::string& file, long long n) {
  auto need = [&](const std::string& name) {
    const int c = t.ColumnIndex(name);
    if (c < 0) {
      throw InvalidInput(file, t.columns_line, name,
                         "required column is missing (expected point,x_mm,y_mm,z_mm,d1_um,…,d" +
                             std::to_string(n) + "_um)");
    }
    return c;
  };
  ReadingColumns col;
  col.point = need("point");
  col.x = need("x_mm");
  col.y = need("y_mm");
  col.z = need("z_mm");
  for (long long j = 1; j <= n; ++j) col.d.push_back(need("d" + std::to_string(j) + "_um"));
  for (const auto& name : t.columns) {
    if (name.size() > 4 && name[0] == 'd' && name.substr(name.size() - 3) == "_um") {
      const auto k = ParseNumber(std::string_view(name).substr(1, name.size() - 4));
      long long kk = 0;
      if (k && AsInt(*k, kk) && (kk < 1 || kk > n)) {
        throw InvalidInput(
            file, t.columns_line, name,
            "column for tracker " + std::to_string(kk) + " but 'trackers' is " + std::to_string(n));
      }
    }
  }
  return col;
}

// The `# beam_break: tracker, point[, at_point|elsewhere]` lines among the data; `by_id` holds
// (id, row) sorted. Without the third field the tracker was re-zeroed at the point (at_point).
std::vector<tracker::BeamBreak> BeamBreaks(
    const TextTable& t, const std::string& file, long long n,
    const std::vector<std::pair<double, std::size_t>>& by_id) {
  std::vector<tracker::BeamBreak> out;
  for (const auto& m : t.markers) {
    if (m.key != "beam_break") {
      throw InvalidInput(file, m.line, m.key,
                         "unexpected '# " + m.key +
                             "' line among the data rows (only "
                             "'# beam_break: tracker, point' is allowed there)");
    }
    std::string_view numbers = m.value;
    bool elsewhere = false;
    const auto second_comma = numbers.find(',', numbers.find(',') + 1);
    if (numbers.find(',') != std::string_view::npos && second_comma != std::string_view::npos) {
      const std::string_view zero = Trim(numbers.substr(second_comma + 1));
      if (zero == "elsewhere") {
        elsewhere = true;
      } else if (zero != "at_point") {
        throw InvalidInput(file, m.line, "beam_break",
                           "the third field says where the tracker was re-zeroed: 'at_point' (at "
                           "the point named, the default) or 'elsewhere' (not at a surveyed "
                           "point), not " +
                               Quote(zero));
      }
      numbers = numbers.substr(0, second_comma);
    }
    const auto v = ParseNumberList(numbers);
    long long j = 0, id = 0;
    if (!v || v->size() != 2 || !AsInt((*v)[0], j) || !AsInt((*v)[1], id)) {
      throw InvalidInput(file, m.line, "beam_break",
                         "expected 'tracker, point' (two integers), optionally followed by "
                         "', at_point' or ', elsewhere'");
    }
    if (j < 1 || j > n) {
      throw InvalidInput(file, m.line, "beam_break",
                         "tracker must be within 1.." + std::to_string(n));
    }
    const auto it = std::lower_bound(by_id.begin(), by_id.end(),
                                     std::make_pair(static_cast<double>(id), std::size_t{0}));
    if (it == by_id.end() || it->first != static_cast<double>(id)) {
      throw InvalidInput(file, m.line, "beam_break",
                         "point " + std::to_string(id) + " is not in the data");
    }
    if (it->second == 0) {
      throw InvalidInput(file, m.line, "beam_break",
                         "a beam break at the first point is meaningless (readings start there)");
    }
    out.push_back({static_cast<int>(j - 1), it->second, elsewhere});
  }
  return out;
}

// The trackers' ranging uncertainty (docs/formats.md §1.2) beyond the generic check of every u_*
// key (text_format.h): a standard uncertainty of a reading above 1 mm is a typing error, and
// draws of it would not describe the survey.
constexpr double kMaxRangingUncertaintyUm = 1000.0;
void CheckRangingUncertainty(const TextTable& t, const std::string& file) {
  const auto u = t.OptionalNumber("u_ranging_um");
  if (u && !(*u <= kMaxRangingUncertaintyUm)) {
    char value[48];
    std::snprintf(value, sizeof value, "%.6g", *u);
    throw InvalidInput(file, t.Find("u_ranging_um")->line, "u_ranging_um",
                       std::string(value) +
                           " µm is not a plausible standard uncertainty of a tracker's ranging "
                           "reading (at most 1000 µm)");
  }
}

}  // namespace

TextLimits DefaultTrackerLimits() {
  TextLimits l;
  l.max_rows = 200'000;
  l.max_columns = 4 + 64 + 60;  // point, x, y, z, d1..d64 and a few more
  l.max_markers = 10'000;
  return l;
}

TrackerFile ParseTrackerFile(std::string_view bytes, const std::string& file,
                             const TextLimits& limits) {
  ReadOptions opt;
  static_cast<TextLimits&>(opt) = limits;
  opt.repeatable_keys = {"tracker_guess_mm"};
  opt.keep_column = [](std::string_view c) {
    return c == "point" || c == "x_mm" || c == "y_mm" || c == "z_mm" || IsReadingColumn(c);
  };
  const TextTable t = ReadTextTable(bytes, file, opt);
  if (t.format != kTrackerFormat) {
    throw InvalidInput(file, t.format_line, "format",
                       "expected '" + std::string(kTrackerFormat) + "', found '" + t.format + "'");
  }
  TrackerFile out;
  auto& r = out.readings;
  out.metadata = t.Metadata();
  r.machine_id = t.RequireMachineId();

  const double nd = t.RequireNumber("trackers");
  long long n = 0;
  if (!AsInt(nd, n) || n < 4) {
    throw InvalidInput(file, t.Find("trackers")->line, "trackers",
                       "must be an integer ≥ 4 (multilateration self-calibration needs at least "
                       "4 trackers or stations)");
  }
  if (n > 64) throw InvalidInput(file, t.Find("trackers")->line, "trackers", "at most 64");
  const std::string mode = t.RequireString("mode");
  if (mode == "simultaneous") {
    r.mode = tracker::TrackerMode::kSimultaneous;
  } else if (mode == "sequential") {
    r.mode = tracker::TrackerMode::kSequential;
  } else {
    throw InvalidInput(file, t.Find("mode")->line, "mode",
                       Quote(mode) + " is neither 'simultaneous' nor 'sequential'");
  }
  CheckRangingUncertainty(t, file);
  r.guesses = TrackerGuesses(t, file, n);
  const ReadingColumns col = FindReadingColumns(t, file, n);
  const int cp = col.point, cx = col.x, cy = col.y, cz = col.z;
  const std::vector<int>& cd = col.d;
  if (t.NumRows() == 0) throw InvalidInput(file, t.columns_line, "", "no data rows");

  // (id, row) sorted by id, rows in file order within an id: repeated ids and the rows of the
  // beam breaks are found in it (16 bytes a point, no node per point).
  const std::size_t rows = t.NumRows();
  std::vector<std::pair<double, std::size_t>> by_id(rows);
  {
    const std::vector<double>& ids = t.Column(static_cast<std::size_t>(cp));
    for (std::size_t i = 0; i < rows; ++i) by_id[i] = {ids[i], i};
    std::sort(by_id.begin(), by_id.end());
  }
  Repeat repeat{rows, rows};
  for (std::size_t k = 1; k < rows; ++k) {
    if (by_id[k].first == by_id[k - 1].first && by_id[k].second < repeat.row) {
      std::size_t g = k - 1;
      while (g > 0 && by_id[g - 1].first == by_id[k].first) --g;
      repeat = {by_id[k].second, by_id[g].second};
    }
  }
  r.point_ids.reserve(rows);
  r.commanded_mm.reserve(rows);
  r.displacement_um.resize(static_cast<long>(rows), static_cast<long>(n));
  for (std::size_t i = 0; i < rows; ++i) {
    const auto row = t.Row(i);
    long long id = 0;
    if (!AsInt(row[static_cast<std::size_t>(cp)], id)) {
      throw InvalidInput(file, t.row_lines[i], "point", "point id must be an integer");
    }
    if (id > std::numeric_limits<int>::max() || id < std::numeric_limits<int>::min()) {
      throw InvalidInput(file, t.row_lines[i], "point",
                         "point id " + std::to_string(id) + " is out of range (at most " +
                             std::to_string(std::numeric_limits<int>::max()) + ")");
    }
    if (i == repeat.row) {
      throw InvalidInput(file, t.row_lines[i], "point",
                         "point " + std::to_string(id) + " repeated (first on line " +
                             std::to_string(t.row_lines[repeat.first]) + ")");
    }
    r.point_ids.push_back(static_cast<int>(id));
    r.commanded_mm.emplace_back(row[static_cast<std::size_t>(cx)],
                                row[static_cast<std::size_t>(cy)],
                                row[static_cast<std::size_t>(cz)]);
    for (long long j = 0; j < n; ++j) {
      r.displacement_um(static_cast<long>(i), static_cast<long>(j)) =
          row[static_cast<std::size_t>(cd[static_cast<std::size_t>(j)])];
    }
  }
  r.beam_breaks = BeamBreaks(t, file, n, by_id);
  return out;
}

std::string WriteTrackerFile(const tracker::TrackerReadings& r) {
  const int n = r.NumTrackers();
  const int m = r.NumPoints();
  if (static_cast<int>(r.point_ids.size()) != m || r.displacement_um.rows() != m) {
    throw InvalidInput("", 0, "readings", "points, ids and readings differ in number");
  }
  std::string s = "# format: " + std::string(kTrackerFormat) + "\n";
  s += "# machine_id: " + r.machine_id + "\n";
  s += "# trackers: " + std::to_string(n) + "\n";
  s += "# mode: " + std::string(tracker::ModeName(r.mode)) + "\n";
  char buf[160];
  for (const auto& g : r.guesses) {
    std::snprintf(buf, sizeof buf, "# tracker_guess_mm: %d, %.6f, %.6f, %.6f\n", g.tracker + 1,
                  g.position_mm.x(), g.position_mm.y(), g.position_mm.z());
    s += buf;
  }
  s += "point,x_mm,y_mm,z_mm";
  for (int j = 1; j <= n; ++j) s += ",d" + std::to_string(j) + "_um";
  s += "\n";
  for (int i = 0; i < m; ++i) {
    for (const auto& b : r.beam_breaks) {
      if (static_cast<int>(b.row) == i) {
        s += "# beam_break: " + std::to_string(b.tracker + 1) + ", " +
             std::to_string(r.point_ids[static_cast<std::size_t>(i)]) +
             (b.elsewhere ? ", elsewhere" : "") + "\n";
      }
    }
    const auto& c = r.commanded_mm[static_cast<std::size_t>(i)];
    std::snprintf(buf, sizeof buf, "%d,%.6f,%.6f,%.6f", r.point_ids[static_cast<std::size_t>(i)],
                  c.x(), c.y(), c.z());
    s += buf;
    for (int j = 0; j < n; ++j) {
      const double d = r.displacement_um(i, j);
      if (!std::isfinite(d)) {
        throw InvalidInput("", 0, "d" + std::to_string(j + 1) + "_um",
                           "a missing reading cannot be written");
      }
      std::snprintf(buf, sizeof buf, ",%.4f", d);
      s += buf;
    }
    s += "\n";
  }
  return s;
}

}  // namespace km::ingest
