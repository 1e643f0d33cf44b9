#include "web/live_state.h"

#include <algorithm>
#include <tuple>

namespace occmap::web {

void LiveState::putMap(std::shared_ptr<const HeldMap> map, SharedBytes frame) {
  {
    const std::lock_guard lock(mutex_);
    map_frame_ = std::move(frame);
    if (recent_.size() == kRecentMaps) recent_.pop_front();
    recent_.push_back(std::move(map));
    ++generations_.map;
    ++counters_.maps;
  }
  changed();
}

void LiveState::putDaemon(DaemonHeard daemon) {
  {
    const std::lock_guard lock(mutex_);
    ++counters_.statuses;
    std::erase_if(daemons_, [&](const DaemonHeard& d) {
      return daemon.heard_ns - d.heard_ns > kForgetDaemonNs;
    });
    const auto same = std::find_if(daemons_.begin(), daemons_.end(),
                                   [&](const DaemonHeard& d) { return d.sameDaemon(daemon); });
    if (same != daemons_.end()) {
      *same = std::move(daemon);
    } else if (daemons_.size() < kMaxDaemons) {
      daemons_.push_back(std::move(daemon));
    } else {
      return;  // full of others: this one is not shown (nothing changed)
    }
    ++generations_.daemons;
  }
  changed();
}

void LiveState::putZones(SharedText json) {
  {
    const std::lock_guard lock(mutex_);
    zones_ = std::move(json);
    ++generations_.zones;
    ++counters_.zones;
  }
  changed();
}

void LiveState::putTracks(SharedText json) {
  {
    const std::lock_guard lock(mutex_);
    tracks_ = std::move(json);
    ++generations_.tracks;
    ++counters_.tracks;
  }
  changed();
}

void LiveState::putPreview(std::shared_ptr<const HeldPreview> preview) {
  {
    const std::lock_guard lock(mutex_);
    ++counters_.previews;
    std::erase_if(previews_, [&](const std::shared_ptr<const HeldPreview>& p) {
      return preview->heard_ns - p->heard_ns > kForgetDaemonNs;
    });
    const auto same = std::find_if(previews_.begin(), previews_.end(), [&](const auto& p) {
      return p->hostname == preview->hostname && p->camera == preview->camera;
    });
    std::size_t held = preview->bytes();
    for (const auto& p : previews_) {
      if (same == previews_.end() || p != *same) held += p->bytes();
    }
    if (held > kMaxPreviewBytes) {
      ++counters_.refused;
      counters_.last_refusal = "a preview of " + preview->hostname + "/" + preview->camera +
                               ": the previews held would pass their memory budget";
      return;
    }
    if (same != previews_.end()) {
      *same = std::move(preview);
    } else if (previews_.size() < kMaxPreviews) {
      previews_.push_back(std::move(preview));
    } else {
      return;
    }
    ++generations_.previews;
  }
  changed();
}

void LiveState::countRefused(std::string what) {
  const std::lock_guard lock(mutex_);
  ++counters_.refused;
  counters_.last_refusal = std::move(what);
}

LiveGenerations LiveState::generations() const {
  const std::lock_guard lock(mutex_);
  return generations_;
}

SharedBytes LiveState::newestMapFrame() const {
  const std::lock_guard lock(mutex_);
  return map_frame_;
}

std::shared_ptr<const HeldMap> LiveState::newestMap() const {
  const std::lock_guard lock(mutex_);
  return recent_.empty() ? nullptr : recent_.back();
}

std::shared_ptr<const HeldMap> LiveState::recentMap(std::int64_t seq) const {
  const std::lock_guard lock(mutex_);
  // Newest first: after a daemon's restart an old map of the same number may still be held.
  for (auto held = recent_.rbegin(); held != recent_.rend(); ++held) {
    if ((*held)->seq == seq) return *held;
  }
  return nullptr;
}

std::vector<DaemonHeard> LiveState::daemons(std::int64_t now_ns) const {
  std::vector<DaemonHeard> heard;
  {
    const std::lock_guard lock(mutex_);
    for (const DaemonHeard& d : daemons_) {
      if (now_ns - d.heard_ns <= kForgetDaemonNs) heard.push_back(d);
    }
  }
  std::stable_sort(heard.begin(), heard.end(), [](const DaemonHeard& a, const DaemonHeard& b) {
    return std::tie(a.hostname, a.merge_node, a.config_file) <
           std::tie(b.hostname, b.merge_node, b.config_file);
  });
  return heard;
}

SharedText LiveState::zones() const {
  const std::lock_guard lock(mutex_);
  return zones_;
}

SharedText LiveState::tracks() const {
  const std::lock_guard lock(mutex_);
  return tracks_;
}

std::shared_ptr<const HeldPreview> LiveState::preview(const std::string& hostname,
                                                      const std::string& camera) const {
  const std::lock_guard lock(mutex_);
  for (const auto& p : previews_) {
    if (p->hostname == hostname && p->camera == camera) return p;
  }
  return nullptr;
}

std::vector<std::shared_ptr<const HeldPreview>> LiveState::previews(std::int64_t now_ns) const {
  std::vector<std::shared_ptr<const HeldPreview>> heard;
  {
    const std::lock_guard lock(mutex_);
    for (const auto& p : previews_) {
      if (now_ns - p->heard_ns <= kForgetDaemonNs) heard.push_back(p);
    }
  }
  std::sort(heard.begin(), heard.end(), [](const auto& a, const auto& b) {
    return std::tie(a->hostname, a->camera) < std::tie(b->hostname, b->camera);
  });
  return heard;
}

LiveCounters LiveState::counters() const {
  const std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace occmap::web
