#include "core/normal_orientation.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <numeric>
#include <tuple>

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

// Joins the forest's components: each round, every component except the largest adds its
// shortest edge to another component (Borůvka), found with k-NN queries that widen until they
// leave the own component.
absl::Status Bridge(const PointCloud& cloud, const Neighbourhoods& nb,
                    const std::vector<uint8_t>& member, DisjointSets& sets,
                    std::vector<Edge>& tree, const CancelToken& cancel, size_t& bridges) {
  const size_t n = cloud.size();
  size_t query_k = 32;
  while (true) {
    uint32_t largest = kNone, components = 0;
    for (uint32_t i = 0; i < n; ++i) {
      if (!member[i] || sets.Find(i) != i) continue;
      ++components;
      if (largest == kNone || sets.Size(i) > sets.Size(largest)) largest = i;
    }
    if (components <= 1) return absl::OkStatus();
    std::vector<uint32_t> root(n, kNone);
    for (uint32_t i = 0; i < n; ++i) {
      if (member[i]) root[i] = sets.Find(i);
    }
    std::vector<float> best_d2(n, std::numeric_limits<float>::infinity());
    std::vector<uint32_t> best_j(n, kNone);
    const size_t kq = std::min(query_k, n);
    absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
      std::vector<uint32_t> idx(kq);
      std::vector<float> d2(kq);
      std::vector<uint64_t> scratch;
      for (size_t i = begin; i < end; ++i) {
        if (root[i] == kNone || root[i] == largest) continue;
        const float q[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
        const size_t found = nb.grid().Knn(q, kq, kNone, 0.f, idx.data(), d2.data(), scratch);
        for (size_t m = 0; m < found; ++m) {
          if (root[idx[m]] != kNone && root[idx[m]] != root[i]) {
            best_d2[i] = d2[m];
            best_j[i] = idx[m];
            break;
          }
        }
      }
    }, 256);
    if (!status.ok()) return status;
    // Per component its shortest outgoing edge, ties to the lowest point index.
    std::vector<uint32_t> pick(n, kNone);
    for (uint32_t i = 0; i < n; ++i) {
      if (best_j[i] == kNone) continue;
      uint32_t& p = pick[root[i]];
      if (p == kNone || best_d2[i] < best_d2[p]) p = i;
    }
    size_t added = 0;
    for (uint32_t r = 0; r < n; ++r) {
      const uint32_t i = pick[r];
      if (i == kNone || !sets.Unite(i, best_j[i])) continue;
      tree.push_back({0.f, std::min(i, best_j[i]), std::max(i, best_j[i])});
      ++added;
      ++bridges;
    }
    if (added == 0) {
      if (kq == n) return absl::InternalError("normal orientation: cannot join graph components");
      query_k *= 4;
    }
  }
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
  ParallelSort(edges.begin(), edges.end());
  if (absl::Status s = cancel.Check(); !s.ok()) return s;

  DisjointSets sets(n);
  std::vector<Edge> tree;
  for (const Edge& e : edges) {
    if (sets.Unite(e.a, e.b)) tree.push_back(e);
  }
  edges = {};
  if (absl::Status s = Bridge(cloud, nb, member, sets, tree, cancel, counts.bridges); !s.ok()) {
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
