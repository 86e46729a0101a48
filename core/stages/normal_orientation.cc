// SPDX-License-Identifier: Apache-2.0
#include "core/stages/normal_orientation.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <numeric>
#include <span>
#include <tuple>

#include <nanoflann.hpp>

#include "core/base/free_memory.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/base/stride.h"

namespace scanprep {
namespace {

bool HasValidNormal(const PointCloud& cloud, size_t i) {
  return !cloud.removed(i) && !(cloud.flags[i] & kNormalInvalid);
}

void Flip(PointCloud& cloud, size_t i) {
  cloud.nx[i] = -cloud.nx[i];
  cloud.ny[i] = -cloud.ny[i];
  cloud.nz[i] = -cloud.nz[i];
}

float AbsDot(const PointCloud& cloud, size_t i, size_t j) {
  return std::abs(cloud.nx[i] * cloud.nx[j] + cloud.ny[i] * cloud.ny[j] +
                  cloud.nz[i] * cloud.nz[j]);
}

class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n), size_(n, 1) {
    std::iota(parent_.begin(), parent_.end(), 0u);
  }
  uint32_t Find(uint32_t a) {
    while (parent_[a] != a) a = parent_[a] = parent_[parent_[a]];
    return a;
  }
  bool Unite(uint32_t a, uint32_t b) {
    a = Find(a), b = Find(b);
    if (a == b) return false;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
    return true;
  }
  uint32_t Size(uint32_t a) { return size_[Find(a)]; }

 private:
  std::vector<uint32_t> parent_, size_;
};

// A bridge's cost: its squared length, scaled up as the normals at its ends differ, since its
// endpoints' normals alone decide whether one side is flipped: across 48° (|cos| 0.67) that is
// a guess where a slightly longer bridge across 26° is not (bun090: a 31 % part came out
// inverted when bridged through a 13-point fragment).
float BridgeCost(const PointCloud& cloud, uint32_t a, uint32_t b) {
  const float disagreement = 2.f - AbsDot(cloud, a, b);
  return cloud.squared_distance(a, b) * disagreement * disagreement;
}

struct Edge {
  float cost;
  uint32_t a, b;
  bool operator<(const Edge& o) const { return std::tie(cost, a, b) < std::tie(o.cost, o.a, o.b); }
};

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

// A nanoflann adaptor over chosen points: ids[i] of the coordinate arrays, or i itself when
// `ids` is empty.
struct SubsetAdaptor {
  const float *x, *y, *z;
  std::span<const uint32_t> ids;
  size_t count;
  size_t kdtree_get_point_count() const { return count; }
  float kdtree_get_pt(uint32_t i, size_t dim) const {
    const uint32_t p = ids.empty() ? i : ids[i];
    return dim == 0 ? x[p] : dim == 1 ? y[p] : z[p];
  }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using SubsetTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, SubsetAdaptor, float, uint32_t>, SubsetAdaptor, 3,
    uint32_t>;

// Components are represented by at most this many of their points when their nearest other
// components are sought, half of them on the component's rim: a query for kSamples more
// neighbours than the own component has samples always reaches other components.
constexpr size_t kSamples = 64;
// Each component is paired with at most this many nearest other components.
constexpr size_t kPartners = 4;
// A bridge starts from a point of the smaller component and ends at its nearest of at most this
// many points of the larger one (a kd-tree, whose build is not cancellable).
constexpr size_t kBridgeTargets = 65536;

// Components that the full k-NN graph links (fragments of one surface split by a gap the
// orientation graph's fewer neighbours do not cross): per point its nearest neighbour in another
// component, then Kruskal over these edges, cheapest first (BridgeCost), into `groups`. So such
// components are bridged by short edges across the gap where the normals on both sides agree.
absl::Status NeighbourBridges(const PointCloud& cloud, const Neighbourhoods& nb,
                              const std::vector<uint32_t>& component, const CancelToken& cancel,
                              DisjointSets& groups, std::vector<Edge>& bridges) {
  const size_t n = cloud.size();
  std::vector<Edge> candidates(n, Edge{std::numeric_limits<float>::infinity(), 0, 0});
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (component[i] == kNone) continue;
      for (const uint32_t j : nb.knn(i)) {  // nearest first
        if (component[j] == kNone || component[j] == component[i]) continue;
        candidates[i] = {BridgeCost(cloud, i, j), std::min<uint32_t>(i, j),
                         std::max<uint32_t>(i, j)};
        break;
      }
    }
  }));
  std::erase_if(candidates, [](const Edge& e) { return !std::isfinite(e.cost); });
  SCANPREP_RETURN_IF_ERROR(CancellableSort(candidates, cancel));
  for (size_t e = 0; e < candidates.size(); ++e) {
    if (cancel.CancelledAt(e)) return cancel.Check();
    if (groups.Unite(component[candidates[e].a], component[candidates[e].b])) {
      bridges.push_back(candidates[e]);
    }
  }
  return absl::OkStatus();
}

// The components of the orientation forest: each member point's component, and each
// component's points contiguously.
struct Components {
  std::vector<uint32_t> of;  // per point; kNone for non-members
  std::vector<uint32_t> start, points;
  size_t size() const { return start.size() - 1; }
  std::span<const uint32_t> members(size_t c) const {
    return std::span<const uint32_t>(points).subspan(start[c], start[c + 1] - start[c]);
  }
};

absl::Status FindComponents(const std::vector<uint8_t>& member, DisjointSets& sets,
                            const CancelToken& cancel, Components& out) {
  const size_t n = member.size();
  out.of.assign(n, kNone);
  std::vector<uint32_t> numbered(n, kNone);  // per root its component
  uint32_t count = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (cancel.CancelledAt(i)) return cancel.Check();
    if (!member[i]) continue;
    uint32_t& c = numbered[sets.Find(i)];
    if (c == kNone) c = count++;
    out.of[i] = c;
  }
  // Counting sort by component.
  out.start.assign(count + 1, 0);
  for (uint32_t i = 0; i < n; ++i) {
    if (out.of[i] != kNone) ++out.start[out.of[i] + 1];
  }
  std::partial_sum(out.start.begin(), out.start.end(), out.start.begin());
  out.points.resize(out.start.back());
  std::vector<uint32_t> fill(out.start.begin(), out.start.end() - 1);
  for (uint32_t i = 0; i < n; ++i) {
    if (out.of[i] != kNone) out.points[fill[out.of[i]]++] = i;
  }
  return absl::OkStatus();
}

// Rim points: their k nearest lie to one side (mean offset over a quarter of d_k; about 0.4 at a
// straight border, near 0 inside). Gaps between parts of one surface run between rims, so a big
// component's few samples must sit there, not spread over its inside.
absl::StatusOr<std::vector<uint8_t>> RimPoints(const PointCloud& cloud, const Neighbourhoods& nb,
                                               const Components& components,
                                               const CancelToken& cancel) {
  std::vector<uint8_t> rim(cloud.size(), 0);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(cloud.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (components.of[i] == kNone || nb.k() == 0) continue;
      Eigen::Vector3f offset = Eigen::Vector3f::Zero();
      for (const uint32_t j : nb.knn(i)) offset += cloud.point(j) - cloud.point(i);
      rim[i] = offset.norm() > 0.25f * nb.k() * nb.dk(i);
    }
  }));
  return rim;
}

// Up to kSamples points of each component (half of them on its rim when it is larger), and the
// component of each.
struct Samples {
  std::vector<uint32_t> point, owner;
};

Samples SampleComponents(const Components& components, const std::vector<uint8_t>& rim) {
  Samples out;
  std::vector<uint32_t> rim_members;
  for (uint32_t c = 0; c < components.size(); ++c) {
    const std::span<const uint32_t> members = components.members(c);
    std::vector<uint32_t> chosen =
        Stride(members, members.size() <= kSamples ? kSamples : kSamples / 2);
    if (members.size() > kSamples) {
      rim_members.clear();
      for (uint32_t i : members) {
        if (rim[i]) rim_members.push_back(i);
      }
      for (uint32_t i : Stride(rim_members, kSamples / 2)) chosen.push_back(i);
    }
    for (uint32_t i : chosen) {
      out.point.push_back(i);
      out.owner.push_back(c);
    }
  }
  return out;
}

// A sample's nearest sample of another component.
struct Near {
  uint32_t component;
  float d2;
  uint32_t other;
  bool operator<(const Near& o) const {
    return std::tie(component, d2, other) < std::tie(o.component, o.d2, o.other);
  }
};

// Per sample its nearest sample of each other component among its k nearest, k reaching
// kSamples past the own component's: not only the nearest component, which may be a small
// fragment in a gap whose normals say little, but the next ones too. Sorted by component, then
// distance. Adds the neighbours asked for to `work`.
absl::StatusOr<std::vector<Near>> NearestOtherComponents(const PointCloud& cloud,
                                                         const Components& components,
                                                         const Samples& samples,
                                                         const CancelToken& cancel, size_t& work) {
  const std::vector<uint32_t>& sample = samples.point;
  const std::vector<uint32_t>& owner = samples.owner;
  const SubsetAdaptor adaptor{cloud.x.data(), cloud.y.data(), cloud.z.data(), sample,
                              sample.size()};
  SubsetTree sample_tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(12));
  sample_tree.buildIndex();
  constexpr size_t kAsk = 2 * kSamples + 1;
  std::vector<Near> near(sample.size() * kPartners, Near{kNone, 0, kNone});
  std::atomic<size_t> asked{0};
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      sample.size(), cancel,
      [&](size_t begin, size_t end) {
        std::vector<uint32_t> idx(kAsk);
        std::vector<float> d2(kAsk);
        size_t local_asked = 0;
        for (size_t s = begin; s < end; ++s) {
          const uint32_t i = sample[s], c = owner[s];
          const size_t k = std::min(components.members(c).size(), kSamples) + kSamples + 1;
          const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
          const size_t found = sample_tree.knnSearch(q, k, idx.data(), d2.data());
          local_asked += k;
          size_t partners = 0;
          for (size_t m = 0; m < found && partners < kPartners; ++m) {
            const uint32_t other = owner[idx[m]];
            bool seen = other == c;
            for (size_t p = 0; p < partners; ++p) seen |= near[s * kPartners + p].other == other;
            if (!seen) near[s * kPartners + partners++] = {c, d2[m], other};
          }
        }
        asked += local_asked;
      },
      256));
  work += asked;
  std::erase_if(near, [](const Near& e) { return e.component == kNone; });
  SCANPREP_RETURN_IF_ERROR(CancellableSort(near, cancel));
  return near;
}

// Per component its kPartners nearest other components (`near` sorted as
// NearestOtherComponents leaves it), each pair once, smaller component first, united in `groups`.
absl::StatusOr<std::vector<std::pair<uint32_t, uint32_t>>> NearestPartners(
    const std::vector<Near>& near, DisjointSets& groups, const CancelToken& cancel) {
  std::vector<std::pair<uint32_t, uint32_t>> found_pairs;
  for (size_t e = 0, taken = 0; e < near.size(); ++e) {
    if (e > 0 && near[e].component != near[e - 1].component) taken = 0;
    bool seen = false;
    for (size_t p = found_pairs.size() - taken; p < found_pairs.size(); ++p) {
      seen |= found_pairs[p].second == near[e].other;
    }
    if (seen || taken == kPartners) continue;
    found_pairs.emplace_back(near[e].component, near[e].other);
    ++taken;
  }
  for (auto& [a, b] : found_pairs) {
    if (a > b) std::swap(a, b);
  }
  SCANPREP_RETURN_IF_ERROR(CancellableSort(found_pairs, cancel));
  found_pairs.erase(std::unique(found_pairs.begin(), found_pairs.end()), found_pairs.end());
  for (const auto& [a, b] : found_pairs) groups.Unite(a, b);
  return found_pairs;
}

// Pairs each group of components that `groups` leaves apart from the largest with the largest,
// at their nearest pair of samples. Adds the neighbours asked for to `work`.
absl::Status LinkToLargestGroup(const PointCloud& cloud, const Components& components,
                                const Samples& samples, DisjointSets& groups,
                                const CancelToken& cancel,
                                std::vector<std::pair<uint32_t, uint32_t>>& pairs, size_t& work) {
  const std::vector<uint32_t>& sample = samples.point;
  const std::vector<uint32_t>& owner = samples.owner;
  const size_t count = components.size();
  std::vector<size_t> group_points(count, 0);
  for (uint32_t c = 0; c < count; ++c) group_points[groups.Find(c)] += components.members(c).size();
  const uint32_t largest = static_cast<uint32_t>(
      std::max_element(group_points.begin(), group_points.end()) - group_points.begin());
  if (group_points[largest] == components.points.size()) return absl::OkStatus();
  std::vector<uint32_t> in_largest;  // samples
  for (size_t s = 0; s < sample.size(); ++s) {
    if (groups.Find(owner[s]) == largest) in_largest.push_back(sample[s]);
  }
  const SubsetAdaptor largest_samples{cloud.x.data(), cloud.y.data(), cloud.z.data(), in_largest,
                                      in_largest.size()};
  SubsetTree largest_tree(3, largest_samples, nanoflann::KDTreeSingleIndexAdaptorParams(12));
  largest_tree.buildIndex();
  std::vector<Edge> nearest(count, Edge{std::numeric_limits<float>::infinity(), 0, 0});
  for (size_t s = 0; s < sample.size(); ++s) {
    if (cancel.CancelledAt(s)) return cancel.Check();
    const uint32_t g = groups.Find(owner[s]);
    if (g == largest) continue;
    const float q[3] = {cloud.x[sample[s]], cloud.y[sample[s]], cloud.z[sample[s]]};
    uint32_t at = 0;
    float d2 = 0;
    largest_tree.knnSearch(q, 1, &at, &d2);
    ++work;
    const Edge candidate{d2, owner[s], components.of[in_largest[at]]};
    if (candidate < nearest[g]) nearest[g] = candidate;
  }
  for (const Edge& e : nearest) {
    if (std::isfinite(e.cost)) pairs.emplace_back(e.a, e.b);
  }
  return absl::OkStatus();
}

// Candidate pairs of components to bridge where the k-NN graph does not link them (separate
// objects, or parts of one surface split by a wide gap), from up to kSamples points of each
// component: each component with the kPartners other components whose samples come nearest to
// its own. Then, if these pairs leave groups apart (a cluster of objects far from the rest),
// each such group is paired with the largest group at their nearest pair of samples, so the
// candidates connect all. Adds the neighbours asked for to `work`.
absl::Status CandidatePairs(const PointCloud& cloud, const Neighbourhoods& nb,
                            const Components& components, DisjointSets groups,
                            const CancelToken& cancel,
                            std::vector<std::pair<uint32_t, uint32_t>>& pairs, size_t& work) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<uint8_t> rim,
                            RimPoints(cloud, nb, components, cancel));
  const Samples samples = SampleComponents(components, rim);
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<Near> near,
                            NearestOtherComponents(cloud, components, samples, cancel, work));
  SCANPREP_ASSIGN_OR_RETURN(const auto nearest_pairs, NearestPartners(near, groups, cancel));
  pairs.insert(pairs.end(), nearest_pairs.begin(), nearest_pairs.end());
  return LinkToLargestGroup(cloud, components, samples, groups, cancel, pairs, work);
}

// Per pair of components its bridge: of the edges from each point of the smaller to its nearest
// of up to kBridgeTargets points of the larger (a kd-tree per larger component), the cheapest
// by BridgeCost. Adds the neighbours asked for to `work`: a pair asks at most the size of the
// component that named it (as one of its kPartners, or as its group's link), so at most
// (kPartners + 1)·n in all.
absl::Status PairBridges(const PointCloud& cloud, const Components& components,
                         std::vector<std::pair<uint32_t, uint32_t>> pairs,
                         const CancelToken& cancel, std::vector<Edge>& bridges, size_t& work) {
  std::vector<uint32_t> tree_of(components.size(), kNone), targets, target_start = {0};
  std::vector<uint32_t> with_tree;
  for (auto& [a, b] : pairs) {
    if (components.members(a).size() < components.members(b).size()) std::swap(a, b);
    if (tree_of[a] != kNone) continue;
    tree_of[a] = static_cast<uint32_t>(with_tree.size());
    with_tree.push_back(a);
    const std::vector<uint32_t> chosen = Stride(components.members(a), kBridgeTargets);
    targets.insert(targets.end(), chosen.begin(), chosen.end());
    target_start.push_back(static_cast<uint32_t>(targets.size()));
  }
  std::vector<std::unique_ptr<SubsetAdaptor>> adaptors(with_tree.size());
  std::vector<std::unique_ptr<SubsetTree>> trees(with_tree.size());
  SCANPREP_RETURN_IF_ERROR(ParallelFor(
      with_tree.size(), cancel,
      [&](size_t begin, size_t end) {
        for (size_t t = begin; t < end; ++t) {
          const size_t size = target_start[t + 1] - target_start[t];
          adaptors[t] = std::make_unique<SubsetAdaptor>(SubsetAdaptor{
              cloud.x.data(), cloud.y.data(), cloud.z.data(),
              std::span<const uint32_t>(targets).subspan(target_start[t], size), size});
          trees[t] = std::make_unique<SubsetTree>(3, *adaptors[t],
                                                  nanoflann::KDTreeSingleIndexAdaptorParams(12));
          trees[t]->buildIndex();
        }
      },
      1));
  const size_t first = bridges.size();
  bridges.resize(first + pairs.size());
  std::atomic<size_t> queries{0};
  const absl::Status status = ParallelFor(
      pairs.size(), cancel,
      [&](size_t begin, size_t end) {
        size_t local_queries = 0;
        for (size_t p = begin; p < end; ++p) {
          const auto [larger, smaller] = pairs[p];
          const size_t t = tree_of[larger];
          Edge best{std::numeric_limits<float>::infinity(), kNone, kNone};
          const std::span<const uint32_t> from = components.members(smaller);
          for (size_t m = 0; m < from.size() && !cancel.CancelledAt(m); ++m) {
            const uint32_t i = from[m];
            const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
            uint32_t at = 0;
            float d2 = 0;
            trees[t]->knnSearch(q, 1, &at, &d2);
            ++local_queries;
            const uint32_t j = targets[target_start[t] + at];
            if (const Edge edge{BridgeCost(cloud, i, j), i, j}; edge < best) best = edge;
          }
          bridges[first + p] = best;
        }
        queries += local_queries;
      },
      16);
  work += queries;  // counted whether or not the loop was cancelled
  return status;
}

// Joins the forest's components in one pass, into a spanning tree: first those that the k-NN
// graph links (NeighbourBridges), then the groups left by the cheapest (BridgeCost) of the
// bridges (PairBridges) of the CandidatePairs. O(n·k) for the k-NN lists and O(n log n) for the
// kd-trees; counts.bridge_work counts the neighbours asked for by kd-tree queries, at most
// 2·kSamples + 1 per sample (kSamples a component) plus (kPartners + 1)·n for the bridges.
absl::Status Bridge(const PointCloud& cloud, const Neighbourhoods& nb,
                    const std::vector<uint8_t>& member, DisjointSets& sets, std::vector<Edge>& tree,
                    const CancelToken& cancel, OrientationCounts& counts) {
  Components components;
  SCANPREP_RETURN_IF_ERROR(FindComponents(member, sets, cancel, components));
  if (components.size() <= 1) return absl::OkStatus();
  DisjointSets groups(components.size());
  std::vector<Edge> bridges;
  SCANPREP_RETURN_IF_ERROR(NeighbourBridges(cloud, nb, components.of, cancel, groups, bridges));
  if (bridges.size() + 1 < components.size()) {
    // The candidates' bridges, Kruskal by their costs, cheapest first.
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    SCANPREP_RETURN_IF_ERROR(
        CandidatePairs(cloud, nb, components, groups, cancel, pairs, counts.bridge_work));
    std::vector<Edge> candidates;
    SCANPREP_RETURN_IF_ERROR(
        PairBridges(cloud, components, std::move(pairs), cancel, candidates, counts.bridge_work));
    SCANPREP_RETURN_IF_ERROR(CancellableSort(candidates, cancel));
    for (const Edge& e : candidates) {
      if (groups.Unite(components.of[e.a], components.of[e.b])) bridges.push_back(e);
    }
  }
  for (const Edge& e : bridges) {
    if (!sets.Unite(e.a, e.b)) return absl::InternalError("normal orientation: bridge in a cycle");
    tree.push_back({0.f, std::min(e.a, e.b), std::max(e.a, e.b)});
    ++counts.bridges;
  }
  return absl::OkStatus();
}

absl::Status Propagate(PointCloud& cloud, const Neighbourhoods& nb, uint32_t k,
                       const std::vector<uint8_t>& member, const CancelToken& cancel,
                       OrientationCounts& counts) {
  const size_t n = cloud.size();
  k = std::min(k, nb.k());
  std::vector<Edge> edges(n * k, Edge{std::numeric_limits<float>::infinity(), 0, 0});
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (!member[i]) continue;
      const auto idx = nb.knn(i);
      for (uint32_t m = 0; m < k; ++m) {
        const uint32_t j = idx[m];
        if (!member[j] || j == i) continue;
        edges[i * k + m] = {1.f - AbsDot(cloud, i, j) + 1e-6f * idx.dist(cloud, m),
                            std::min<uint32_t>(i, j), std::max<uint32_t>(i, j)};
      }
    }
  }));
  std::erase_if(edges, [](const Edge& e) { return !std::isfinite(e.cost); });
  SCANPREP_RETURN_IF_ERROR(CancellableSort(edges, cancel));

  DisjointSets sets(n);
  std::vector<Edge> tree;
  for (size_t e = 0; e < edges.size(); ++e) {
    if (cancel.CancelledAt(e)) return cancel.Check();
    if (sets.Unite(edges[e].a, edges[e].b)) tree.push_back(edges[e]);
  }
  FreeMemory(edges);
  SCANPREP_RETURN_IF_ERROR(Bridge(cloud, nb, member, sets, tree, cancel, counts));

  // Tree adjacency in CSR form.
  std::vector<uint32_t> offset(n + 1, 0), adjacent(2 * tree.size());
  for (const Edge& e : tree) ++offset[e.a + 1], ++offset[e.b + 1];
  std::partial_sum(offset.begin(), offset.end(), offset.begin());
  std::vector<uint32_t> fill(offset.begin(), offset.end() - 1);
  for (const Edge& e : tree) adjacent[fill[e.a]++] = e.b, adjacent[fill[e.b]++] = e.a;

  uint32_t seed = kNone;
  for (uint32_t i = 0; i < n; ++i) {
    if (member[i] && (seed == kNone || cloud.z[i] > cloud.z[seed])) seed = i;
  }
  if (seed == kNone) return absl::OkStatus();
  if (cloud.nz[seed] < 0) Flip(cloud, seed);
  std::vector<uint8_t> visited(n, 0);
  std::vector<uint32_t> queue = {seed};
  visited[seed] = 1;
  for (size_t head = 0; head < queue.size(); ++head) {
    if (cancel.CancelledAt(head)) return cancel.Check();
    const uint32_t parent = queue[head];
    for (uint32_t e = offset[parent]; e < offset[parent + 1]; ++e) {
      const uint32_t child = adjacent[e];
      if (visited[child]) continue;
      visited[child] = 1;
      if (cloud.nx[child] * cloud.nx[parent] + cloud.ny[child] * cloud.ny[parent] +
              cloud.nz[child] * cloud.nz[parent] <
          0) {
        Flip(cloud, child);
      }
      queue.push_back(child);
    }
  }
  counts.propagated = queue.size();
  return absl::OkStatus();
}

}  // namespace

std::optional<Eigen::Vector3d> TowardSensor(const ScanMeta& scan, const Eigen::Vector3d& p) {
  if (scan.camera_position) return *scan.camera_position - p;
  if (scan.projector_position) return *scan.projector_position - p;
  if (scan.view_direction) return *scan.view_direction;
  if (scan.projector_direction) return *scan.projector_direction;
  return std::nullopt;
}

absl::Status OrientNormals(PointCloud& cloud, const Neighbourhoods& nb, uint32_t k,
                           const CancelToken& cancel, OrientationCounts& counts) {
  const size_t n = cloud.size();
  std::vector<uint8_t> propagate(n, 0);
  std::atomic<size_t> toward{0}, left{0};
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    size_t local_toward = 0, local_left = 0;
    for (size_t i = begin; i < end; ++i) {
      if (!HasValidNormal(cloud, i)) continue;
      const std::optional<Eigen::Vector3d> view =
          TowardSensor(cloud.scans[cloud.scan[i]], cloud.point(i).cast<double>());
      if (!view) {
        propagate[i] = 1;
        ++local_left;
        continue;
      }
      if (cloud.normal(i).cast<double>().dot(*view) < 0) Flip(cloud, i);  // Eq. (3)
      ++local_toward;
    }
    toward += local_toward;
    left += local_left;
  }));
  counts.toward_sensor = toward;
  if (left == 0) return absl::OkStatus();
  return Propagate(cloud, nb, k, propagate, cancel, counts);
}

}  // namespace scanprep
