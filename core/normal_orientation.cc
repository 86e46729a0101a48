#include "core/normal_orientation.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <numeric>
#include <span>
#include <tuple>

#include <nanoflann.hpp>

#include "core/parallel.h"

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
  return std::abs(cloud.nx[i] * cloud.nx[j] + cloud.ny[i] * cloud.ny[j] + cloud.nz[i] * cloud.nz[j]);
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
  bool kdtree_get_bbox(BBox&) const { return false; }
};
using SubsetTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<float, SubsetAdaptor, float, uint32_t>, SubsetAdaptor, 3,
    uint32_t>;

// Each component links to the components of its kCentroidNeighbours nearest centroids.
constexpr size_t kCentroidNeighbours = 8;
// A bridge is the closest pair between at most this many points of the smaller component
// (queries) and at most kBridgeTargets points of the larger one (a kd-tree): exact for small
// components, a bounded sample of big ones, where the bridge only has to be short, not shortest.
constexpr size_t kBridgeQueries = 64;
constexpr size_t kBridgeTargets = 8192;

// Up to `cap` of `points`, evenly strided.
std::vector<uint32_t> Stride(std::span<const uint32_t> points, size_t cap) {
  if (points.size() <= cap) return {points.begin(), points.end()};
  std::vector<uint32_t> out(cap);
  for (size_t t = 0; t < cap; ++t) out[t] = points[t * points.size() / cap];
  return out;
}

// Joins the forest's components in one pass. A spanning tree over the components comes from
// Kruskal on the edges to each component's nearest centroids (shortest first); groups those
// edges leave apart (clusters of centroids far from each other) are then each joined to the
// largest group at their nearest centroid pair. Every chosen pair gets one bridge edge, its
// closest sampled point pair. The work is O(C·log C) for C components plus O(n log n) for the
// per-component kd-trees; counts.bridge_work counts the neighbours asked for by all queries (at
// most C·(kCentroidNeighbours + 2) + kBridgeQueries·(C − 1)), the bound the tests assert.
absl::Status Bridge(const PointCloud& cloud, const std::vector<uint8_t>& member,
                    DisjointSets& sets, std::vector<Edge>& tree, const CancelToken& cancel,
                    OrientationCounts& counts) {
  const size_t n = cloud.size();
  // Component of every member point, and each component's points contiguously (counting sort).
  std::vector<uint32_t> component(n, kNone), first_point(n, kNone);
  uint32_t components = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (cancel.CancelledAt(i)) return cancel.Check();
    if (!member[i]) continue;
    uint32_t& c = first_point[sets.Find(i)];
    if (c == kNone) c = components++;
    component[i] = c;
  }
  if (components <= 1) return absl::OkStatus();
  first_point = {};
  std::vector<uint32_t> start(components + 1, 0), points;
  for (uint32_t i = 0; i < n; ++i) {
    if (component[i] != kNone) ++start[component[i] + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  points.resize(start.back());
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t i = 0; i < n; ++i) {
      if (component[i] != kNone) points[fill[component[i]]++] = i;
    }
  }
  auto members = [&](uint32_t c) {
    return std::span<const uint32_t>(points).subspan(start[c], start[c + 1] - start[c]);
  };
  std::vector<float> cx(components), cy(components), cz(components);
  absl::Status status = ParallelFor(components, cancel, [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (uint32_t i : members(c)) sum += cloud.point(i).cast<double>();
      sum /= static_cast<double>(members(c).size());
      cx[c] = static_cast<float>(sum.x()), cy[c] = static_cast<float>(sum.y());
      cz[c] = static_cast<float>(sum.z());
    }
  }, 64);
  if (!status.ok()) return status;

  // Candidate component pairs: each centroid's nearest other centroids.
  const SubsetAdaptor all_centroids{cx.data(), cy.data(), cz.data(), {}, components};
  SubsetTree centroid_tree(3, all_centroids, nanoflann::KDTreeSingleIndexAdaptorParams(12));
  centroid_tree.buildIndex();
  const size_t kc = std::min<size_t>(kCentroidNeighbours + 1, components);
  std::vector<Edge> candidates(components * kc, Edge{std::numeric_limits<float>::infinity(), 0, 0});
  status = ParallelFor(components, cancel, [&](size_t begin, size_t end) {
    std::vector<uint32_t> idx(kc);
    std::vector<float> d2(kc);
    for (size_t c = begin; c < end; ++c) {
      const float q[3] = {cx[c], cy[c], cz[c]};
      const size_t found = centroid_tree.knnSearch(q, kc, idx.data(), d2.data());
      for (size_t m = 0; m < found; ++m) {
        if (idx[m] == c) continue;
        candidates[c * kc + m] = {d2[m], std::min<uint32_t>(c, idx[m]),
                                  std::max<uint32_t>(c, idx[m])};
      }
    }
  }, 256);
  if (!status.ok()) return status;
  counts.bridge_work += components * kc;
  std::erase_if(candidates, [](const Edge& e) { return !std::isfinite(e.cost); });
  if (absl::Status s = CancellableSort(candidates, cancel); !s.ok()) return s;
  DisjointSets groups(components);
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (size_t e = 0; e < candidates.size(); ++e) {
    if (cancel.CancelledAt(e)) return cancel.Check();
    if (groups.Unite(candidates[e].a, candidates[e].b)) {
      pairs.emplace_back(candidates[e].a, candidates[e].b);
    }
  }
  candidates = {};

  // Groups still apart: each joins the largest group (by points) at its nearest centroid pair.
  if (pairs.size() + 1 < components) {
    std::vector<size_t> group_points(components, 0);
    for (uint32_t c = 0; c < components; ++c) group_points[groups.Find(c)] += members(c).size();
    const uint32_t largest = static_cast<uint32_t>(
        std::max_element(group_points.begin(), group_points.end()) - group_points.begin());
    std::vector<uint32_t> in_largest;
    for (uint32_t c = 0; c < components; ++c) {
      if (groups.Find(c) == largest) in_largest.push_back(c);
    }
    const SubsetAdaptor largest_centroids{cx.data(), cy.data(), cz.data(), in_largest,
                                          in_largest.size()};
    SubsetTree largest_tree(3, largest_centroids, nanoflann::KDTreeSingleIndexAdaptorParams(12));
    largest_tree.buildIndex();
    std::vector<Edge> nearest(components, Edge{std::numeric_limits<float>::infinity(), 0, 0});
    for (uint32_t c = 0; c < components; ++c) {
      if (cancel.CancelledAt(c)) return cancel.Check();
      const uint32_t g = groups.Find(c);
      if (g == largest) continue;
      const float q[3] = {cx[c], cy[c], cz[c]};
      uint32_t at = 0;
      float d2 = 0;
      largest_tree.knnSearch(q, 1, &at, &d2);
      if (Edge candidate{d2, c, in_largest[at]}; candidate < nearest[g]) nearest[g] = candidate;
    }
    counts.bridge_work += components - in_largest.size();
    for (const Edge& e : nearest) {
      if (std::isfinite(e.cost)) pairs.emplace_back(e.a, e.b);
    }
  }

  // One bridge per pair: the larger component of each pair needs a kd-tree over its targets.
  std::vector<uint32_t> tree_of(components, kNone), targets, target_start = {0};
  std::vector<uint32_t> with_tree;
  for (auto& [a, b] : pairs) {
    if (members(a).size() < members(b).size()) std::swap(a, b);  // a: the larger
    if (tree_of[a] != kNone) continue;
    tree_of[a] = static_cast<uint32_t>(with_tree.size());
    with_tree.push_back(a);
    const std::vector<uint32_t> chosen = Stride(members(a), kBridgeTargets);
    targets.insert(targets.end(), chosen.begin(), chosen.end());
    target_start.push_back(static_cast<uint32_t>(targets.size()));
  }
  std::vector<std::unique_ptr<SubsetAdaptor>> adaptors(with_tree.size());
  std::vector<std::unique_ptr<SubsetTree>> trees(with_tree.size());
  status = ParallelFor(with_tree.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t) {
      const size_t size = target_start[t + 1] - target_start[t];
      adaptors[t] = std::make_unique<SubsetAdaptor>(SubsetAdaptor{
          cloud.x.data(), cloud.y.data(), cloud.z.data(),
          std::span<const uint32_t>(targets).subspan(target_start[t], size), size});
      trees[t] = std::make_unique<SubsetTree>(3, *adaptors[t],
                                              nanoflann::KDTreeSingleIndexAdaptorParams(12));
      trees[t]->buildIndex();
    }
  }, 1);
  if (!status.ok()) return status;
  std::vector<Edge> bridges(pairs.size());
  std::atomic<size_t> queries{0};
  status = ParallelFor(pairs.size(), cancel, [&](size_t begin, size_t end) {
    size_t local_queries = 0;
    for (size_t p = begin; p < end; ++p) {
      const auto [larger, smaller] = pairs[p];
      const size_t t = tree_of[larger];
      Edge best{std::numeric_limits<float>::infinity(), kNone, kNone};
      for (uint32_t i : Stride(members(smaller), kBridgeQueries)) {
        const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
        uint32_t at = 0;
        float d2 = 0;
        trees[t]->knnSearch(q, 1, &at, &d2);
        ++local_queries;
        if (d2 < best.cost) best = {d2, i, targets[target_start[t] + at]};
      }
      bridges[p] = best;
    }
    queries += local_queries;
  }, 16);
  if (!status.ok()) return status;
  counts.bridge_work += queries;
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
  absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (!member[i]) continue;
      const auto idx = nb.knn(i);
      for (uint32_t m = 0; m < k; ++m) {
        const uint32_t j = idx[m];
        if (!member[j] || j == i) continue;
        edges[i * k + m] = {1.f - AbsDot(cloud, i, j) + 1e-6f * nb.knn_dist(cloud, i, m),
                            std::min<uint32_t>(i, j), std::max<uint32_t>(i, j)};
      }
    }
  });
  if (!status.ok()) return status;
  std::erase_if(edges, [](const Edge& e) { return !std::isfinite(e.cost); });
  if (absl::Status s = CancellableSort(edges, cancel); !s.ok()) return s;

  DisjointSets sets(n);
  std::vector<Edge> tree;
  for (size_t e = 0; e < edges.size(); ++e) {
    if (cancel.CancelledAt(e)) return cancel.Check();
    if (sets.Unite(edges[e].a, edges[e].b)) tree.push_back(edges[e]);
  }
  edges = {};
  if (absl::Status s = Bridge(cloud, member, sets, tree, cancel, counts); !s.ok()) {
    return s;
  }

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
              cloud.nz[child] * cloud.nz[parent] < 0) {
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
  absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
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
  });
  if (!status.ok()) return status;
  counts.toward_sensor = toward;
  if (left == 0) return absl::OkStatus();
  return Propagate(cloud, nb, k, propagate, cancel, counts);
}

}  // namespace scanprep
