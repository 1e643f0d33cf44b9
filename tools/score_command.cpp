// occmap score: detections on the floor against the truth, in the CLEAR MOD measures that
// multi-camera people detection is compared by (WILDTRACK, MVDet). occmap truth: the ground truth
// of EPFL's data sets as the truth file occmap score reads.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/exit_codes.h"
#include "config/floor_points_file.h"
#include "config/input_error.h"
#include "core/detection_score.h"
#include "core/track_score.h"
#include "tools/commands.h"

namespace occmap::tools {
namespace {

struct ScoreOptions {
  std::string truth;
  std::string detections;
  std::string tracks;
  double gate_m = 0.5;
  std::optional<std::int64_t> frames;
  bool json = false;
};

using Frames = std::map<std::int64_t, std::vector<FloorPoint>>;

Frames byFrame(const std::vector<FloorPointRow>& rows) {
  Frames frames;
  for (const FloorPointRow& row : rows) frames[row.frame].push_back(row.point);
  return frames;
}

// The frames scored: those the truth names, and with --frames every frame from 0 (a frame
// without truth rows then has nobody in it).
template <class ByFrame>
std::set<std::int64_t> scoredFrames(const ByFrame& truth, const ScoreOptions& o) {
  std::set<std::int64_t> scored;
  for (const auto& entry : truth) scored.insert(entry.first);
  if (o.frames) {
    for (std::int64_t frame = 0; frame < *o.frames; ++frame) scored.insert(frame);
  }
  if (scored.empty()) {
    throw InputError(o.truth, 0, "", "has no rows and --frames was not given: nothing to score");
  }
  return scored;
}

// Tracks against a truth with identities: MOTA and IDF1 over the frames the truth names (or
// 0..N-1).
int runTrackScore(const ScoreOptions& o) {
  using Rows = std::map<std::int64_t, std::vector<FloorPointRow>>;
  Rows truth, tracks;
  for (const FloorPointRow& row : readFloorPointsCsv(o.truth, "truth", "id")) {
    truth[row.frame].push_back(row);
  }
  for (const FloorPointRow& row : readFloorPointsCsv(o.tracks, "tracks", "track_id")) {
    tracks[row.frame].push_back(row);
  }
  const std::set<std::int64_t> scored = scoredFrames(truth, o);
  TrackScorer scorer(o.gate_m);
  std::vector<FloorPoint> truth_points, track_points;
  std::vector<std::int64_t> truth_ids, track_ids;
  for (const std::int64_t frame : scored) {
    truth_points.clear();
    truth_ids.clear();
    track_points.clear();
    track_ids.clear();
    if (const auto t = truth.find(frame); t != truth.end()) {
      for (const FloorPointRow& row : t->second) {
        truth_points.push_back(row.point);
        truth_ids.push_back(*row.id);
      }
    }
    if (const auto t = tracks.find(frame); t != tracks.end()) {
      for (const FloorPointRow& row : t->second) {
        track_points.push_back(row.point);
        track_ids.push_back(*row.id);
      }
    }
    scorer.addFrame(truth_points, truth_ids, track_points, track_ids);
  }
  const TrackScore s = scorer.score();
  if (o.json) {
    const nlohmann::json out = {
        {"frames", s.frames}, {"truth", s.truth},       {"tracks", s.tracks},
        {"pairs", s.pairs},   {"switches", s.switches}, {"id_pairs", s.id_pairs},
        {"mota", s.mota()},   {"idf1", s.idf1()},       {"gate_m", o.gate_m}};
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("scored %zu frames: %zu truth points, %zu track points, %zu paired within %.2f m\n",
              s.frames, s.truth, s.tracks, s.pairs, o.gate_m);
  std::printf("MOTA       %7.2f %%   (misses %zu, false positives %zu, identity switches %zu)\n",
              100.0 * s.mota(), s.truth - s.pairs, s.tracks - s.pairs, s.switches);
  std::printf("IDF1       %7.2f %%   (%zu points on identities paired once for the sequence)\n",
              100.0 * s.idf1(), s.id_pairs);
  return kExitOk;
}

int runScore(const ScoreOptions& o) {
  if (o.detections.empty() == o.tracks.empty()) {
    throw InputError("", 0, "--detections", "give --detections or --tracks, one of them");
  }
  if (!o.tracks.empty()) return runTrackScore(o);
  const Frames truth = byFrame(readFloorPointsCsv(o.truth, "truth"));
  const Frames found = byFrame(readFloorPointsCsv(o.detections, "detections"));
  const std::set<std::int64_t> scored = scoredFrames(truth, o);
  DetectionScorer scorer(o.gate_m);
  const std::vector<FloorPoint> none;
  for (const std::int64_t frame : scored) {
    const auto t = truth.find(frame);
    const auto d = found.find(frame);
    scorer.addFrame(t == truth.end() ? none : t->second, d == found.end() ? none : d->second);
  }
  std::size_t left_out = 0;  // detections in frames not scored: said, never silently dropped
  std::size_t left_out_frames = 0;
  for (const auto& [frame, points] : found) {
    if (scored.count(frame) != 0) continue;
    left_out += points.size();
    ++left_out_frames;
  }
  const DetectionScore& s = scorer.score();
  if (o.json) {
    const nlohmann::json out = {
        {"frames", s.frames},
        {"people", s.people},
        {"detections", s.detections},
        {"pairs", s.pairs},
        {"misses", s.misses()},
        {"false_positives", s.falsePositives()},
        {"moda", s.moda()},
        {"modp", s.modp()},
        {"precision", s.precision()},
        {"recall", s.recall()},
        {"mean_distance_m", s.pairs == 0 ? 0.0 : s.distance_m / static_cast<double>(s.pairs)},
        {"gate_m", o.gate_m},
        {"detections_outside_scored_frames", left_out}};
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("scored %zu frames: %zu people, %zu detections, %zu paired within %.2f m\n", s.frames,
              s.people, s.detections, s.pairs, o.gate_m);
  std::printf("MODA       %7.2f %%   (misses %zu, false positives %zu)\n", 100.0 * s.moda(),
              s.misses(), s.falsePositives());
  std::printf("MODP       %7.2f %%   (mean distance of a pair %.3f m)\n", 100.0 * s.modp(),
              s.pairs == 0 ? 0.0 : s.distance_m / static_cast<double>(s.pairs));
  std::printf("precision  %7.2f %%\nrecall     %7.2f %%\n", 100.0 * s.precision(),
              100.0 * s.recall());
  if (left_out > 0) {
    std::printf(
        "note: %zu detections in %zu frames that the truth does not name were not scored; "
        "--frames N scores frames 0 to N-1, a frame without truth rows as one with nobody in it\n",
        left_out, left_out_frames);
  }
  return kExitOk;
}

struct TruthOptions {
  std::string epfl;
  std::string out;
};

int runTruth(const TruthOptions& o) {
  const std::vector<FloorPointRow> rows = readEpflGroundTruth(o.epfl);
  std::ofstream out(o.out);
  if (!out) throw InputError(o.out, 0, "", "cannot write the truth file here");
  out << "frame,x_m,y_m\n";
  char line[96];
  for (const FloorPointRow& row : rows) {
    std::snprintf(line, sizeof line, "%lld,%.4f,%.4f\n", static_cast<long long>(row.frame),
                  row.point.x_m, row.point.y_m);
    out << line;
  }
  out.close();
  if (!out) throw InputError(o.out, 0, "", "writing the truth file failed");
  std::int64_t last = 0;
  for (const FloorPointRow& row : rows) last = std::max(last, row.frame);
  // Frames with nobody in them have no line, in EPFL's file as in this one: --frames says they
  // were looked at.
  std::printf(
      "%zu people in frames 0 to %lld written to %s (score with --frames %lld, so that frames "
      "with nobody in them count too)\n",
      rows.size(), static_cast<long long>(last), o.out.c_str(), static_cast<long long>(last + 1));
  return kExitOk;
}

}  // namespace

Command addScoreCommand(CLI::App& app) {
  auto options = std::make_shared<ScoreOptions>();
  CLI::App* command = app.add_subcommand(
      "score",
      "Detections on the floor against the truth: MODA, MODP, precision and recall, the measures "
      "multi-camera people detection is compared by (WILDTRACK, MVDet).\n"
      "In each frame the truth and the detections are paired by the optimal assignment (the "
      "Hungarian method): the most pairs closer than the gate (0.5 m), then the least total "
      "distance. MODA = 1 - (misses + false positives) / people; MODP = the mean over pairs of "
      "1 - distance / gate.\n"
      "Both files are CSV with a header naming the columns frame, x_m and y_m (others, such as "
      "area_m2 and score, are left alone); frame is the frame set's index from 0. "
      "The frames scored are those the truth names (and with --frames N, frames 0 to N-1).\n"
      "With --tracks: MOTA = 1 - (misses + false positives + identity switches) / truth points "
      "(last frame's pairs kept while within the gate), and IDF1, each truth identity paired "
      "once for the whole sequence with the track that shares the most frames with it.\n\n"
      "Example (EPFL Terrace's ground truth, docs/detection.md):\n"
      "  occmap truth --epfl ../shared/data/epfl-terrace/gt.txt --out truth.csv\n"
      "  occmap score --truth truth.csv --detections detections.csv --frames 10");
  command->add_option("--truth", options->truth, "Truth CSV: frame,x_m,y_m[,...]")->required();
  command->add_option("--detections", options->detections, "Detections CSV: frame,x_m,y_m[,...]");
  command->add_option("--tracks", options->tracks,
                      "Instead: tracks CSV (frame,track_id,x_m,y_m[,...]) against a truth with an "
                      "id column: MOTA and IDF1");
  command->add_option("--gate-m", options->gate_m, "Largest distance of a pair, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--frames", options->frames,
                   "Score frames 0 to N-1, those without truth rows as frames with nobody in them")
      ->check(CLI::PositiveNumber);
  command->add_flag("--json", options->json, "Print one JSON object instead of the table");
  return [options] { return runScore(*options); };
}

Command addTruthCommand(CLI::App& app) {
  auto options = std::make_shared<TruthOptions>();
  CLI::App* command = app.add_subcommand(
      "truth",
      "Writes a ground truth as the truth file occmap score reads (frame,x_m,y_m).\n"
      "--epfl reads EPFL's gt.txt ('index source_frame x_mm y_mm' a line; the index is the "
      "moment's, the same as the masks' file number and the frame set's index).\n\n"
      "Example:\n"
      "  occmap truth --epfl ../shared/data/epfl-terrace-crowd/gt.txt --out crowd-truth.csv");
  command->add_option("--epfl", options->epfl, "EPFL ground truth file (gt.txt)")->required();
  command->add_option("--out", options->out, "Truth CSV to write")->required();
  return [options] { return runTruth(*options); };
}

}  // namespace occmap::tools
