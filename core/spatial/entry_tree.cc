// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/entry_tree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <nanoflann.hpp>

namespace scanprep {
namespace {

// nanoflann's build cannot be interrupted from outside; the adaptor it reads the points through
// throws this when the job's token fires, looked at every 2^16 reads (a few hundred microseconds).
struct BuildCancelled {};

struct EntryAdaptor {
  std::span<const GridEntry> entries;
  const CancelToken* cancel = nullptr;
  mutable uint32_t reads = 0;

  size_t kdtree_get_point_count() const { return entries.size(); }
  // Read by the build only: queries read the entries through EntryDistance.
  float kdtree_get_pt(uint32_t e, size_t dim) const {
    if ((++reads & 0xffff) == 0 && cancel != nullptr && cancel->cancelled()) {
      throw BuildCancelled();
    }
    const GridEntry& p = entries[e];
    return dim == 0 ? p.x : dim == 1 ? p.y : p.z;
  }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

// nanoflann's L2_Simple_Adaptor summed the same way ((dx² + dy²) + dz² in float, the grid's
// order), counting every point it is asked about.
struct EntryDistance {
  using ElementType = float;
  using DistanceType = float;
  const EntryAdaptor& data;
  explicit EntryDistance(const EntryAdaptor& adaptor) : data(adaptor) {}
  float evalMetric(const float* q, uint32_t e, size_t) const {
    ++candidates_examined_by_this_thread;
    const GridEntry& p = data.entries[e];
    const float dx = q[0] - p.x, dy = q[1] - p.y, dz = q[2] - p.z;
    return dx * dx + dy * dy + dz * dz;
  }
  template <typename U, typename V>
  float accum_dist(const U a, const V b, size_t) const {
    return (a - b) * (a - b);
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<EntryDistance, EntryAdaptor, 3, uint32_t>;

// nanoflann's result-set interface over NearestQuery: the `count` smallest keys in a max-heap
// (the worst on top), or every key when count is unbounded.
class KeySet {
 public:
  KeySet(const NearestQuery& query, std::span<const uint32_t> ids, std::vector<uint64_t>& keys)
      : query_(query), ids_(ids), keys_(keys), bounded_(query.count != SIZE_MAX) {}

  bool addPoint(float d2, uint32_t e) {
    const uint32_t id = ids_[e];
    if (id == query_.exclude) return true;
    if (query_.flags != nullptr && (query_.flags[id] & query_.skip) != 0) return true;
    const uint64_t key = uint64_t{std::bit_cast<uint32_t>(d2)} << 32 | id;
    if (keys_.size() < query_.count) {
      keys_.push_back(key);
      if (bounded_) std::push_heap(keys_.begin(), keys_.end());
    } else if (key < keys_.front()) {
      std::pop_heap(keys_.begin(), keys_.end());
      keys_.back() = key;
      std::push_heap(keys_.begin(), keys_.end());
    }
    return true;
  }
  bool full() const { return keys_.size() >= query_.count; }
  // nanoflann offers a point only when its distance is below this, and visits a node only when
  // its lower bound is at most this: once full, the next float above the worst kept distance, so
  // a point tied with it (which wins on a lower index) is still offered, and the answer is the
  // grid's to the last tie.
  float worstDist() const {
    if (keys_.size() < query_.count) return query_.limit_sq;
    return std::nextafter(std::bit_cast<float>(static_cast<uint32_t>(keys_.front() >> 32)),
                          HUGE_VALF);
  }

 private:
  const NearestQuery& query_;
  std::span<const uint32_t> ids_;
  std::vector<uint64_t>& keys_;
  const bool bounded_;
};

// Leaves of up to 16 points: a k = 20 query reads two or three.
constexpr size_t kLeafSize = 16;

}  // namespace

struct EntryTree::Index {
  EntryAdaptor adaptor;
  std::span<const uint32_t> ids;
  std::unique_ptr<KdTree> tree;
};

EntryTree::EntryTree(std::unique_ptr<Index> index) : index_(std::move(index)) {}
EntryTree::~EntryTree() = default;

absl::StatusOr<std::unique_ptr<EntryTree>> EntryTree::Build(std::span<const GridEntry> entries,
                                                            std::span<const uint32_t> ids,
                                                            const CancelToken& cancel) {
  auto index = std::make_unique<Index>();
  index->adaptor.entries = entries;
  index->adaptor.cancel = &cancel;
  index->ids = ids;
  try {
    index->tree = std::make_unique<KdTree>(3, index->adaptor,
                                           nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  } catch (const BuildCancelled&) {
    return absl::CancelledError("job cancelled");
  }
  index->adaptor.cancel = nullptr;  // the token need not outlive the build
  return std::unique_ptr<EntryTree>(new EntryTree(std::move(index)));
}

void EntryTree::Nearest(const float q[3], const NearestQuery& query,
                        std::vector<uint64_t>& keys) const {
  keys.clear();
  if (query.count == 0 || index_->adaptor.entries.empty()) return;
  KeySet set(query, index_->ids, keys);
  // Exact (eps 0): nanoflann's node bounds, as in the reference kd-tree.
  index_->tree->findNeighbors(set, q, nanoflann::SearchParams(32, 0.f));
}

}  // namespace scanprep
