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

// Points [begin, end) of `chunk`, whose arrays are in the repeated form: xyz and normal three
// values per point, the others one. An array shorter than the range gives what it has, so a
// mismatch reaches the chunk's checks as it was sent.
v1::PointChunk SliceChunk(const v1::PointChunk& chunk, uint64_t begin, uint64_t end);

// Appends `from`'s points to `to`, array by array in whichever form each came (both chunks in
// the same form), and its flags.
void AppendChunk(const v1::PointChunk& from, v1::PointChunk& to);

}  // namespace scanprep
