// SPDX-License-Identifier: Apache-2.0
// Per-point fields of a file that no stage reads (a colour, a scanner's own scalars): the readers
// keep them, the client sends none of them, and the writers store them back for the points that
// come back (by PointChunk.source_index), so that nothing a file carried is dropped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace scanprep {

// The file's storage type, so that a writer stores each value back as it was read.
enum class AttributeType : uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64,
  // A 4-byte float field that holds a bit pattern, not a number (PCL's packed colour "rgb",
  // 0xAARRGGBB, often a NaN): kept as that uint32 and written back as a float with the same bits,
  // which a value through double would not keep (a signalling NaN comes back quieted).
  kFloat32Bits
};

// Bytes of one value of `type` in a binary file.
int AttributeBytes(AttributeType type);

struct PointAttribute {
  std::string name;  // as the file names it ("red", "confidence_2")
  AttributeType type = AttributeType::kFloat32;
  // One value per point in `type`'s bytes (host order), not as double: a colour channel holds
  // one byte a point, an eighth of what a double would (300 MB instead of 2.4 GB for three
  // channels of 100 M points). Values go in and come out as double, which holds every value of
  // every type exactly.
  std::vector<uint8_t> data;

  size_t size() const { return data.size() / AttributeBytes(type); }
  double Value(size_t i) const;
  // `value` must be one of the type's values (HoldsValue): a reader checks what a file's text
  // says before it stores it, as converting a double outside a type's range is undefined.
  void Set(size_t i, double value);
  void Append(double value);
  void Resize(size_t n) { data.resize(n * AttributeBytes(type)); }
  // The values stored again in `to` (each must be one of `to`'s values).
  void ConvertTo(AttributeType to);
};
bool IsIntegerAttribute(AttributeType type);
// Whether `value` is one of `type`'s values: an integer type's integers in its range; a float
// within float's range (or not finite; rounded to the nearest float); kFloat32Bits a uint32.
bool HoldsValue(AttributeType type, double value);
bool IsSignedAttribute(AttributeType type);

// The attributes of clouds joined end to end (a job's files, an E57 file's scans): those every
// part has under one name and type, each part's values appended in order. The names of the
// others go to left_out[p] for the part p that has them: a note, never a silent drop.
std::vector<PointAttribute> JoinAttributes(
    const std::vector<const std::vector<PointAttribute>*>& parts,
    std::vector<std::vector<std::string>>& left_out);

// `from`'s attributes for the points `positions` index, in that order (the result's points by
// their source_index). Every position must be below each attribute's size.
std::vector<PointAttribute> GatherAttributes(const std::vector<PointAttribute>& from,
                                             const std::vector<uint32_t>& positions);

}  // namespace scanprep
