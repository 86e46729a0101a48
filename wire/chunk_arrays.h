// SPDX-License-Identifier: Apache-2.0
// The two forms of a PointChunk's per-point arrays: the repeated fields and their *_packed
// little-endian byte twins (scanprep.proto). The server and the C++ client work on the repeated
// form; these convert at the edge, a memcpy per array.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep {

// Moves every packed array of `chunk` into its repeated twin. INVALID_ARGUMENT when an array
// comes in both forms or its byte count is not a multiple of 4; `bad_array` then names it
// (e.g. "xyz_packed").
absl::Status UnpackArrays(v1::PointChunk& chunk, std::string& bad_array);

// Moves every repeated array of `chunk` into its packed twin.
void PackArrays(v1::PointChunk& chunk);

// The points of `chunk`: its xyz values over 3, in whichever form they came.
uint64_t ChunkPoints(const v1::PointChunk& chunk);

// Whether any array of `chunk` is in the packed form.
bool HasPackedArrays(const v1::PointChunk& chunk);

}  // namespace scanprep
