// `kinemetric stream profile FRAMES …`: a captured stream (binary frames or NDJSON, the HTTP
// stream formats of docs/streams.md) turned into a straightness profile and analysed offline —
// the same path as POST /api/v1/streams/{id}/profile, without a server. Gaps and duplicates
// are judged like the server does (ingest/stream/stream_counters.h) and reported.
#include <algorithm>
#include <fstream>
#include <map>
#include <ostream>

#include "analysis/core/errors.h"
#include "cli/command.h"
#include "ingest/form_parsers.h"
#include "ingest/stream/stream_counters.h"
#include "ingest/stream/stream_frames.h"
#include "usecases/form_report.h"
#include "usecases/stream_profile.h"

namespace km::cli {
namespace {

using nlohmann::json;

struct Channel {
  ingest::ChannelCounters counters;
  ingest::SampleRun samples;
  std::vector<ingest::CounterGap> gaps;
  std::uint64_t duplicates = 0;
};

int RunStreamProfile(const Args& args, std::ostream& out) {
  if (args.positional.size() != 1) {
    throw InvalidInput("", 0, "FRAMES", "give one file of stream frames");
  }
  const std::string path = args.positional.front();
  std::string format = args.Get("--format").value_or("");
  if (format.empty()) {
    const bool nd = path.size() > 6 && (path.ends_with(".ndjson") || path.ends_with(".jsonl"));
    format = nd ? "ndjson" : "binary";
  }
  if (format != "binary" && format != "ndjson") {
    throw InvalidInput("", 0, "--format", "'" + format + "' is not binary or ndjson");
  }
  const auto channel_opt = args.Get("--channel");
  if (!channel_opt) throw InvalidInput("", 0, "--channel", "the sensor channel is required");
  const auto channel = static_cast<std::uint32_t>(args.GetNumber("--channel", 0));
  std::optional<std::uint32_t> encoder;
  if (args.Has("--encoder-channel")) {
    encoder = static_cast<std::uint32_t>(args.GetNumber("--encoder-channel", 0));
  }
  usecases::ProfileSpec spec;
  spec.machine_id = args.Get("--machine-id").value_or("stream");
  spec.axis = args.Get("--axis").value_or("");
  spec.error_direction = args.Get("--error-direction").value_or("");
  if (spec.axis.empty()) throw InvalidInput("", 0, "--axis", "the travel axis is required");
  if (spec.error_direction.empty()) {
    throw InvalidInput("", 0, "--error-direction", "the error direction is required");
  }
  spec.points = static_cast<std::size_t>(args.GetNumber("--points", 1000));
  spec.feed_mm_min = args.GetNumber("--feed-mm-min", 0.0);
  spec.start_mm = args.GetNumber("--start-mm", 0.0);
  if (!encoder && spec.feed_mm_min == 0.0) {
    throw InvalidInput("", 0, "--feed-mm-min",
                       "give the feed (with --start-mm) or an --encoder-channel for positions");
  }
  spec.provenance = {{"source_file", path}};

  ingest::StreamFrameDecoder decoder(
      format == "ndjson" ? ingest::FrameFormat::kNdjson : ingest::FrameFormat::kBinary, path);
  std::map<std::uint32_t, Channel> channels;
  const auto on_run = [&](ingest::SampleRun&& run) {
    if (run.channel != channel && (!encoder || run.channel != *encoder)) return;
    Channel& c = channels[run.channel];
    const auto v = c.counters.Take(run);
    c.duplicates += v.duplicates;
    if (v.gap) c.gaps.push_back(*v.gap);
    const auto skip = static_cast<std::ptrdiff_t>(v.duplicates);
    c.samples.channel = run.channel;
    c.samples.t_us.insert(c.samples.t_us.end(), run.t_us.begin() + skip, run.t_us.end());
    c.samples.value_um.insert(c.samples.value_um.end(), run.value_um.begin() + skip,
                              run.value_um.end());
  };
  decoder.Feed(ReadFileBytes(path), on_run);
  decoder.Finish(on_run);
  Channel& sensor = channels[channel];
  sensor.samples.channel = channel;
  const ingest::SampleRun* enc = nullptr;
  if (encoder) {
    channels[*encoder].samples.channel = *encoder;
    enc = &channels[*encoder].samples;
  }
  std::string text;
  try {
    text = usecases::StraightnessFileFromStream(spec, sensor.samples, enc);
  } catch (const InvalidInput& e) {
    const std::map<std::string, std::string> option_of{
        {"channel", "--channel"},
        {"position.encoder_channel", "--encoder-channel"},
        {"position.feed_mm_min", "--feed-mm-min"},
        {"bins", "--points"},
        {"position", "--feed-mm-min"}};
    const auto it = option_of.find(e.field());
    throw InvalidInput(path, 0, it != option_of.end() ? it->second : e.field(), e.reason());
  }
  if (const auto w = args.Get("--write-profile")) {
    std::ofstream f(*w, std::ios::binary);
    f << text;
    if (!f) throw InvalidInput(*w, 0, "--write-profile", "cannot write the profile file");
  }
  const auto file = ingest::ParseStraightnessFile(text, path + " (profile)");
  json j = usecases::StraightnessFilesToJson({file});
  json gaps = json::array();
  for (const auto& [id, c] : channels) {
    for (const auto& g : c.gaps) {
      gaps.push_back({{"channel", id},
                      {"first_missing", g.first_missing},
                      {"missing", g.missing},
                      {"t_before_us", g.t_before_us},
                      {"t_after_us", g.t_after_us}});
    }
  }
  j["stream"] = {{"frames", decoder.frames()},
                 {"sensor_samples", sensor.samples.size()},
                 {"profile_points", file.profile.position_mm.size()},
                 {"duplicates", sensor.duplicates},
                 {"gaps", gaps}};
  if (args.json) {
    out << j.dump(2) << "\n";
    return 0;
  }
  out << path << ": channel " << channel << ", " << sensor.samples.size() << " samples → "
      << file.profile.position_mm.size() << " profile points, " << gaps.size() << " gaps\n"
      << "  straightness (least squares) " << j["straightness_lsq_um"].get<double>() << " um\n"
      << "  straightness (minimum zone)  " << j["straightness_min_zone_um"].get<double>() << " um\n"
      << "  slope (least squares)        " << j["slope_um_per_m"].get<double>() << " um/m\n";
  for (const auto& c : j["periodic"]) {
    out << "  periodic: period " << c["period_mm"].get<double>() << " mm, amplitude "
        << c["amplitude_um"].get<double>() << " um\n";
  }
  return 0;
}

}  // namespace

KM_CLI_COMMAND("stream profile",
               "FRAMES --channel C --axis X --error-direction Z (--feed-mm-min F [--start-mm S] | "
               "--encoder-channel E) [--points N] [--machine-id M] [--format binary|ndjson] "
               "[--write-profile FILE] [--json]",
               {"--channel", "--axis", "--error-direction", "--feed-mm-min", "--start-mm",
                "--encoder-channel", "--points", "--machine-id", "--format", "--write-profile"},
               RunStreamProfile);

}  // namespace km::cli
