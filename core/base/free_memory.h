// SPDX-License-Identifier: Apache-2.0
// Gives a container's memory back now. `v = {}` does not: for std::vector and std::string it
// picks operator=(initializer_list), which empties the container and keeps its capacity, so an
// array "freed" before a stage's peak was still held through it.
#pragma once

namespace scanprep {

template <typename Container>
void FreeMemory(Container& c) {
  Container().swap(c);
}

}  // namespace scanprep
