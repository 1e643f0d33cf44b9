#include "core/tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

namespace occmap {

Tracker::Tracker(const TrackerSettings& settings) : settings_(settings) {
  if (!(settings.gate_m > 0) || !(settings.position_noise_m > 0) ||
      !(settings.acceleration_m_s2 >= 0) || settings.confirm_hits < 1 ||
      !(settings.lost_after_s > 0) || settings.reported_missed_maps < 0) {
    throw std::invalid_argument(
        "Tracker: gate, noise and times must be positive, reported_missed_maps not negative");
  }
  // Room for a crowd, so that following one allocates nothing (more grow the buffers once).
  constexpr std::size_t kRoom = 64;
  states_.reserve(kRoom);
  out_.reserve(kRoom);
  cost_.reserve(kRoom * kRoom);
  tier_cost_.reserve(kRoom * kRoom);
  used_.reserve(kRoom);
  assignment_.reserve(kRoom, kRoom);
}

void Tracker::predict(State& state, double dt) const {
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(0, 2) = dt;
  f(1, 3) = dt;
  // White acceleration: the discrete process noise of a constant-velocity model.
  const double q = settings_.acceleration_m_s2 * settings_.acceleration_m_s2;
  const double dt2 = dt * dt, dt3 = dt2 * dt / 2, dt4 = dt2 * dt2 / 4;
  Eigen::Matrix4d noise = Eigen::Matrix4d::Zero();
  for (int axis = 0; axis < 2; ++axis) {
    noise(axis, axis) = dt4 * q;
    noise(axis, axis + 2) = noise(axis + 2, axis) = dt3 * q;
    noise(axis + 2, axis + 2) = dt2 * q;
  }
  state.x = f * state.x;
  state.p = f * state.p * f.transpose() + noise;
}

void Tracker::correct(State& state, const Detection& detection, double time_s) const {
  Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
  h(0, 0) = 1;
  h(1, 1) = 1;
  const double r = settings_.position_noise_m * settings_.position_noise_m;
  const Eigen::Matrix2d s = h * state.p * h.transpose() + Eigen::Matrix2d::Identity() * r;
  const Eigen::Matrix<double, 4, 2> gain = state.p * h.transpose() * s.inverse();
  const Eigen::Vector2d innovation(detection.x_m - state.x(0), detection.y_m - state.x(1));
  state.x += gain * innovation;
  state.p = (Eigen::Matrix4d::Identity() - gain * h) * state.p;
  state.track.area_m2 = detection.area_m2;
  state.last_s = time_s;
  state.missed = 0;
  if (detection.held) return;
  state.seen_s = time_s;
  ++state.hits;
}

const std::vector<Track>& Tracker::update(std::span<const Detection> detections, double time_s) {
  const double dt = started_ ? time_s - time_s_ : 0.0;
  if (dt < 0) throw std::invalid_argument("Tracker: time went back");
  started_ = true;
  time_s_ = time_s;
  for (State& state : states_) {
    predict(state, dt);
    ++state.missed;  // until a detection is given to it
  }
  // Detections to predicted tracks: the most pairs within the gate, then the least distance.
  cost_.resize(states_.size() * detections.size());
  tier_cost_.resize(cost_.size());
  for (std::size_t t = 0; t < states_.size(); ++t) {
    for (std::size_t d = 0; d < detections.size(); ++d) {
      cost_[t * detections.size() + d] =
          std::hypot(detections[d].x_m - states_[t].x(0), detections[d].y_m - states_[t].x(1));
    }
  }
  // Confirmed tracks first, then the tentative ones from what is left: a tentative track, born
  // of a stray or a ghost beside someone, would otherwise take that person's detection from their
  // track when nearer its prediction (room-crowd's first 300 maps: MOTA 67.4 -> 72.0 %, IDF1
  // 42.5 -> 51.4 %; the room unchanged). Also ranking the confirmed tracks seen on this map's
  // predecessor above those coasting (DeepSORT's cascade) helped the crowd more but cost the
  // room (MOTA 96.7 -> 91.1 %): not kept.
  used_.assign(detections.size(), 0);
  constexpr double kNoPair = std::numeric_limits<double>::infinity();
  for (const bool confirmed : {true, false}) {
    for (std::size_t t = 0; t < states_.size(); ++t) {
      for (std::size_t d = 0; d < detections.size(); ++d) {
        const std::size_t i = t * detections.size() + d;
        // Someone held where a confirmed track expected them is for confirmed tracks alone (given
        // in the same tier as those found: a tier of their own after them, the room's IDF1
        // 98.6 -> 91.5 %).
        const bool pairable = used_[d] == 0 && (confirmed || !detections[d].held);
        tier_cost_[i] = states_[t].track.confirmed == confirmed && pairable ? cost_[i] : kNoPair;
      }
    }
    const std::vector<int>& pairs =
        assignment_.solve(tier_cost_, states_.size(), detections.size(), settings_.gate_m);
    for (std::size_t t = 0; t < states_.size(); ++t) {
      if (pairs[t] < 0) continue;
      used_[static_cast<std::size_t>(pairs[t])] = 1;
      correct(states_[t], detections[static_cast<std::size_t>(pairs[t])], time_s);
    }
  }
  // Tracks end: tentative ones not confirmed in time, any not seen for lost_after_s.
  std::erase_if(states_, [&](const State& state) {
    const bool unconfirmed_too_long =
        !state.track.confirmed && time_s - state.first_s > settings_.confirm_within_s;
    return time_s - state.seen_s > settings_.lost_after_s || unconfirmed_too_long;
  });
  // Confirmed against the tracks confirmed on earlier maps (their ids come before this map's):
  // two people who appear together are both confirmed, whatever the distance; a double appears
  // beside what it doubles.
  const double apart2 = settings_.confirm_apart_m * settings_.confirm_apart_m;
  const std::uint32_t first_new_id = next_id_;
  for (State& state : states_) {
    if (state.track.confirmed || state.hits < settings_.confirm_hits) continue;
    const bool twice = std::any_of(states_.begin(), states_.end(), [&](const State& other) {
      return other.track.confirmed && other.track.id < first_new_id &&
             (other.x.head<2>() - state.x.head<2>()).squaredNorm() < apart2;
    });
    if (twice) continue;
    state.track.confirmed = true;
    state.track.id = next_id_++;
  }
  // New tentative tracks, at rest where they were found, their velocity as uncertain as a
  // walk (2 m/s).
  for (std::size_t d = 0; d < detections.size(); ++d) {
    if (used_[d] != 0 || detections[d].held) continue;
    State state;
    state.x << detections[d].x_m, detections[d].y_m, 0.0, 0.0;
    const double r = settings_.position_noise_m * settings_.position_noise_m;
    state.p = Eigen::Vector4d(r, r, 4.0, 4.0).asDiagonal();
    state.first_s = state.last_s = state.seen_s = time_s;
    state.hits = 1;
    state.track.area_m2 = detections[d].area_m2;
    if (settings_.confirm_hits <= 1) {
      state.track.confirmed = true;
      state.track.id = next_id_++;
    }
    states_.push_back(state);
  }
  out_.clear();
  for (State& state : states_) {
    if (!state.track.confirmed || state.missed > settings_.reported_missed_maps) continue;
    state.track.x_m = state.x(0);
    state.track.y_m = state.x(1);
    state.track.vx_m_s = state.x(2);
    state.track.vy_m_s = state.x(3);
    state.track.age_s = time_s - state.first_s;
    // Since the evidence last found it: a track held while hidden says how long it has been.
    state.track.unseen_s = time_s - state.seen_s;
    out_.push_back(state.track);
  }
  return out_;
}

void Tracker::expectedAt(double time_s, double within_s, std::vector<Eigen::Vector2d>& out) const {
  if (!started_) return;
  const double dt = std::max(0.0, time_s - time_s_);
  for (const State& state : states_) {
    if (!state.track.confirmed || time_s - state.last_s > within_s) continue;
    out.emplace_back(state.x(0) + dt * state.x(2), state.x(1) + dt * state.x(3));
  }
}

}  // namespace occmap
