// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/duplicates.h"

#include <bit>
#include <utility>

#include "core/pipeline/parallel.h"
#include "core/status_macros.h"

namespace scanprep {
namespace {

// Coordinates compare as floats (−0 equals 0), so hash them with −0 folded into 0.
uint32_t Bits(float v) { return std::bit_cast<uint32_t>(v + 0.0f); }

uint64_t Mix(uint64_t h) {  // splitmix64's finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

bool SamePoint(const PointCloud& cloud, uint32_t a, uint32_t b) {
  return cloud.scan[a] == cloud.scan[b] && cloud.x[a] == cloud.x[b] && cloud.y[a] == cloud.y[b] &&
         cloud.z[a] == cloud.z[b];
}

template <typename T>
void KeepFirsts(const std::vector<T>& from, const std::vector<uint32_t>& firsts,
                std::vector<T>& to) {
  if (from.empty()) return;
  to.resize(firsts.size());
  for (size_t g = 0; g < firsts.size(); ++g) to[g] = from[firsts[g]];
}

}  // namespace

absl::StatusOr<DuplicateGroups> FindDuplicates(const PointCloud& cloud, const CancelToken& cancel) {
  const size_t n = cloud.size();
  // (hash, index) sorted: equal points are adjacent, the lowest index first.
  std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
  absl::Status status = ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      uint64_t h = Mix(cloud.scan[i] ^ (uint64_t(Bits(cloud.x[i])) << 32));
      h = Mix(h ^ Bits(cloud.y[i]) ^ (uint64_t(Bits(cloud.z[i])) << 32));
      keyed[i] = {h, static_cast<uint32_t>(i)};
    }
  });
  if (!status.ok()) return status;
  SCANPREP_RETURN_IF_ERROR(CancellableSort(keyed, cancel));

  // first[i]: the lowest index of i's group. Within a run of equal hashes each point is
  // compared with the run's distinct points so far (one, unless 64-bit hashes collide).
  std::vector<uint32_t> first(n);
  std::vector<uint32_t> distinct;
  for (size_t begin = 0, runs = 0; begin < n; ++runs) {
    if ((runs & 0xffff) == 0) {
      SCANPREP_RETURN_IF_ERROR(cancel.Check());
    }
    size_t end = begin + 1;
    while (end < n && keyed[end].first == keyed[begin].first) ++end;
    distinct.clear();
    for (size_t e = begin; e < end; ++e) {
      const uint32_t i = keyed[e].second;
      uint32_t group = i;
      for (const uint32_t d : distinct) {
        if (SamePoint(cloud, d, i)) group = d;
      }
      if (group == i) distinct.push_back(i);
      first[i] = group;
    }
    begin = end;
  }

  DuplicateGroups groups;
  groups.group_of.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (first[i] == i) {
      groups.group_of[i] = static_cast<uint32_t>(groups.multiplicity.size());
      groups.multiplicity.push_back(1);
    } else {
      groups.group_of[i] = groups.group_of[first[i]];  // first[i] < i: already numbered
      ++groups.multiplicity[groups.group_of[i]];
    }
  }
  return groups;
}

PointCloud CompactDuplicates(const PointCloud& cloud, const DuplicateGroups& groups) {
  std::vector<uint32_t> firsts;
  firsts.reserve(groups.multiplicity.size());
  for (size_t i = 0; i < groups.group_of.size(); ++i) {
    if (groups.group_of[i] == firsts.size()) firsts.push_back(static_cast<uint32_t>(i));
  }
  PointCloud compact;
  compact.scans = cloud.scans;
  compact.kind = cloud.kind;
  for (auto member : {&PointCloud::x, &PointCloud::y, &PointCloud::z, &PointCloud::quality,
                      &PointCloud::intensity, &PointCloud::nx, &PointCloud::ny, &PointCloud::nz}) {
    KeepFirsts(cloud.*member, firsts, compact.*member);
  }
  KeepFirsts(cloud.scan, firsts, compact.scan);
  KeepFirsts(cloud.scanline, firsts, compact.scanline);
  KeepFirsts(cloud.flags, firsts, compact.flags);
  return compact;
}

void ExpandDuplicates(const PointCloud& compact, const DuplicateGroups& groups, PointCloud& cloud) {
  const size_t n = cloud.size();
  if (compact.has_normals()) {
    cloud.nx.resize(n), cloud.ny.resize(n), cloud.nz.resize(n);
  }
  for (size_t i = 0; i < n; ++i) {
    const uint32_t g = groups.group_of[i];
    cloud.x[i] = compact.x[g], cloud.y[i] = compact.y[g], cloud.z[i] = compact.z[g];
    if (compact.has_normals()) {
      cloud.nx[i] = compact.nx[g], cloud.ny[i] = compact.ny[g], cloud.nz[i] = compact.nz[g];
    }
    cloud.flags[i] = compact.flags[g];
  }
}

}  // namespace scanprep
