// SPDX-License-Identifier: Apache-2.0
// Label values held by recency, to bound a metric's cardinality without giving the first comers
// their labels for the server's lifetime (issue 39 finding 6: any client could spend the 64
// sensor labels, and the plant's own sensors then never got one).
#pragma once

#include <cstdint>
#include <iterator>
#include <list>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace scanprep::metrics {

class LabelSlots {
 public:
  explicit LabelSlots(int capacity) : capacity_(capacity) {}

  struct Use {
    bool held = false;                   // false: no slot for the value, it is folded
    std::optional<std::string> evicted;  // the value whose slot it took
  };
  // The value used in round `round` (non-decreasing; SensorMetrics counts jobs): it keeps or
  // takes a slot. When all are held, the least recently used value gives up its slot, unless it
  // was used in this round too: then every slot is in use by the round and the value gets none.
  Use Take(const std::string& value, uint64_t round) {
    if (const auto it = slot_of_.find(value); it != slot_of_.end()) {
      it->second->round = round;
      by_recency_.splice(by_recency_.end(), by_recency_, it->second);
      return {.held = true};
    }
    Use use{.held = capacity_ > 0};
    if (static_cast<int>(by_recency_.size()) >= capacity_) {
      if (!use.held || by_recency_.front().round == round) return {};
      use.evicted = by_recency_.front().value;
      slot_of_.erase(by_recency_.front().value);
      by_recency_.pop_front();
    }
    by_recency_.push_back({value, round});
    slot_of_[value] = std::prev(by_recency_.end());
    return use;
  }

  // Gives up the slots of the values `drop` is true for; returns those values.
  template <typename Predicate>
  std::vector<std::string> ReleaseIf(Predicate drop) {
    std::vector<std::string> released;
    for (auto it = by_recency_.begin(); it != by_recency_.end();) {
      if (!drop(it->value)) {
        ++it;
        continue;
      }
      released.push_back(it->value);
      slot_of_.erase(it->value);
      it = by_recency_.erase(it);
    }
    return released;
  }

 private:
  struct Slot {
    std::string value;
    uint64_t round;
  };
  const int capacity_;
  std::list<Slot> by_recency_;  // the least recently used first
  std::map<std::string, std::list<Slot>::iterator> slot_of_;
};

}  // namespace scanprep::metrics
