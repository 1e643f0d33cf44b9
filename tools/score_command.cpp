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

using Rows = std::map<std::int64_t, std::vector<FloorPointRow>>;

Rows byFrame(const std::vector<FloorPointRow>& rows) {
  Rows frames;
  for (const FloorPointRow& row : rows) frames[row.frame].push_back(row);
  return frames;
}

// The points of `frame`'s rows (and their ids, when asked for).
void pointsAt(const Rows& rows, std::int64_t frame, std::vector<FloorPoint>& points,
              std::vector<std::int64_t>* ids = nullptr) {
  points.clear();
  if (ids != nullptr) ids->clear();
  const auto found = rows.find(frame);
  if (found == rows.end()) return;
  for (const FloorPointRow& row : found->second) {
    points.push_back(row.point);
    if (ids != nullptr) ids->push_back(*row.id);
  }
}

// The frames scored: those the truth names, and with --frames every frame from 0 (a frame
// without truth rows then has nobody in it).
std::set<std::int64_t> scoredFrames(const Rows& truth, const ScoreOptions& o) {
  std::set<std::int64_t> scored;
  for (const auto& [frame, rows] : truth) scored.insert(frame);
  if (o.frames) {
    for (std::int64_t frame = 0; frame < *o.frames; ++frame) scored.insert(frame);
  }
  if (scored.empty()) {
    throw InputError(o.truth, 0, "", "has no rows and --frames was not given: nothing to score");
  }
  return scored;
}

// Rows in frames not scored: counted and said, never dropped silently.
struct LeftOut {
  std::size_t rows = 0;
  std::size_t frames = 0;
};
LeftOut leftOut(const Rows& rows, const std::set<std::int64_t>& scored) {
  LeftOut out;
  for (const auto& [frame, those] : rows) {
    if (scored.count(frame) != 0) continue;
    out.rows += those.size();
    ++out.frames;
  }
  return out;
}
void printLeftOut(const LeftOut& left_out, const char* what) {
  if (left_out.rows == 0) return;
  std::printf(
      "note: %zu %s in %zu frames that the truth does not name were not scored; --frames N "
      "scores frames 0 to N-1, a frame without truth rows as one with nobody in it\n",
      left_out.rows, what, left_out.frames);
}

// Tracks against a truth with identities: MOTA and IDF1.
int runTrackScore(const ScoreOptions& o) {
  const Rows truth = byFrame(readFloorPointsCsv(o.truth, "truth", "id"));
  const Rows tracks = byFrame(readFloorPointsCsv(o.tracks, "tracks", "track_id"));
  const std::set<std::int64_t> scored = scoredFrames(truth, o);
  TrackScorer scorer(o.gate_m);
  std::vector<FloorPoint> truth_points, track_points;
  std::vector<std::int64_t> truth_ids, track_ids;
  for (const std::int64_t frame : scored) {
    pointsAt(truth, frame, truth_points, &truth_ids);
    pointsAt(tracks, frame, track_points, &track_ids);
    scorer.addFrame(truth_points, truth_ids, track_points, track_ids);
  }
  const LeftOut left_out = leftOut(tracks, scored);
  const TrackScore s = scorer.score();
  if (o.json) {
    const nlohmann::json out = {
        {"frames", s.frames},     {"truth", s.truth},
        {"tracks", s.tracks},     {"pairs", s.pairs},
        {"switches", s.switches}, {"id_pairs", s.id_pairs},
        {"mota", s.mota()},       {"idf1", s.idf1()},
        {"gate_m", o.gate_m},     {"tracks_outside_scored_frames", left_out.rows}};
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("scored %zu frames: %zu truth points, %zu track points, %zu paired within %.2f m\n",
              s.frames, s.truth, s.tracks, s.pairs, o.gate_m);
  std::printf("MOTA       %7.2f %%   (misses %zu, false positives %zu, identity switches %zu)\n",
              100.0 * s.mota(), s.truth - s.pairs, s.tracks - s.pairs, s.switches);
  std::printf("IDF1       %7.2f %%   (%zu points on identities paired once for the sequence)\n",
              100.0 * s.idf1(), s.id_pairs);
  printLeftOut(left_out, "track points");
  return kExitOk;
}

int runScore(const ScoreOptions& o) {
  if (o.detections.empty() == o.tracks.empty()) {
    throw InputError("", 0, "--detections", "give --detections or --tracks, one of them");
  }
  if (!o.tracks.empty()) return runTrackScore(o);
  const Rows truth = byFrame(readFloorPointsCsv(o.truth, "truth"));
  const Rows found = byFrame(readFloorPointsCsv(o.detections, "detections"));
  const std::set<std::int64_t> scored = scoredFrames(truth, o);
  DetectionScorer scorer(o.gate_m);
  std::vector<FloorPoint> truth_points, found_points;
  for (const std::int64_t frame : scored) {
    pointsAt(truth, frame, truth_points);
    pointsAt(found, frame, found_points);
    scorer.addFrame(truth_points, found_points);
  }
  const LeftOut left_out = leftOut(found, scored);
  const DetectionScore& s = scorer.score();
  const double mean_distance_m = s.pairs == 0 ? 0.0 : s.distance_m / static_cast<double>(s.pairs);
  if (o.json) {
    const nlohmann::json out = {{"frames", s.frames},
                                {"people", s.people},
                                {"detections", s.detections},
                                {"pairs", s.pairs},
                                {"misses", s.misses()},
                                {"false_positives", s.falsePositives()},
                                {"moda", s.moda()},
                                {"modp", s.modp()},
                                {"precision", s.precision()},
                                {"recall", s.recall()},
                                {"mean_distance_m", mean_distance_m},
                                {"gate_m", o.gate_m},
                                {"detections_outside_scored_frames", left_out.rows}};
    std::printf("%s\n", out.dump().c_str());
    return kExitOk;
  }
  std::printf("scored %zu frames: %zu people, %zu detections, %zu paired within %.2f m\n", s.frames,
              s.people, s.detections, s.pairs, o.gate_m);
  std::printf("MODA       %7.2f %%   (misses %zu, false positives %zu)\n", 100.0 * s.moda(),
              s.misses(), s.falsePositives());
  std::printf("MODP       %7.2f %%   (mean distance of a pair %.3f m)\n", 100.0 * s.modp(),
              mean_distance_m);
  std::printf("precision  %7.2f %%\nrecall     %7.2f %%\n", 100.0 * s.precision(),
              100.0 * s.recall());
  printLeftOut(left_out, "detections");
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
