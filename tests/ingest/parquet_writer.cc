#include "tests/ingest/parquet_writer.h"

#include <snappy.h>

#include <cstring>

namespace wm::parquet::testing {
namespace {

// Thrift compact protocol, writing side.
class ThriftWriter {
 public:
  void I32(int16_t id, int64_t v) { Header(id, 5), out_ += Varint(ZigZag(v)); }
  void I64(int16_t id, int64_t v) { Header(id, 6), out_ += Varint(ZigZag(v)); }
  void Bool(int16_t id, bool v) { Header(id, v ? 1 : 2); }
  void Binary(int16_t id, const std::string& s) { Header(id, 8), out_ += Varint(s.size()) + s; }
  void BeginStruct(int16_t id) { Header(id, 12), last_.push_back(0); }
  void End() { out_ += '\0', last_.pop_back(); }
  void BeginList(int16_t id, uint8_t element_type, size_t n) {
    Header(id, 9);
    if (n < 15)
      out_ += static_cast<char>((n << 4) | element_type);
    else
      out_ += static_cast<char>(0xf0 | element_type) + Varint(n);
  }
  void ListStruct() { last_.push_back(0); }  // an element struct; close with End()
  void ListBinary(const std::string& s) { out_ += Varint(s.size()) + s; }
  void ListI32(int64_t v) { out_ += Varint(ZigZag(v)); }
  std::string Take() { return std::move(out_); }

 private:
  static uint64_t ZigZag(int64_t v) { return (static_cast<uint64_t>(v) << 1) ^ (v >> 63); }
  void Header(int16_t id, uint8_t type) {
    const int delta = id - last_.back();
    if (delta > 0 && delta <= 15)
      out_ += static_cast<char>((delta << 4) | type);
    else
      out_ += static_cast<char>(type) + Varint(ZigZag(id));
    last_.back() = id;
  }
  std::string out_;
  std::vector<int16_t> last_{0};
};

template <typename T>
std::string Plain(const std::vector<T>& v) {
  std::string out(v.size() * sizeof(T), '\0');
  std::memcpy(out.data(), v.data(), out.size());
  return out;
}

}  // namespace

std::string Varint(uint64_t v) {
  std::string out;
  do {
    out += static_cast<char>((v & 0x7f) | (v >= 0x80 ? 0x80 : 0));
    v >>= 7;
  } while (v);
  return out;
}

std::string RleRun(uint32_t value, uint64_t count, int bit_width) {
  std::string out = Varint(count << 1);
  for (int b = 0; b < (bit_width + 7) / 8; ++b) out += static_cast<char>((value >> (8 * b)) & 0xff);
  return out;
}

std::string BitPackedRun(const std::vector<uint32_t>& values, int bit_width) {
  const size_t groups = (values.size() + 7) / 8;
  std::string bits(groups * bit_width, '\0');
  for (size_t i = 0; i < values.size(); ++i) {
    for (int b = 0; b < bit_width; ++b) {
      const size_t bit = i * bit_width + b;
      if ((values[i] >> b) & 1) bits[bit / 8] = static_cast<char>(bits[bit / 8] | (1 << (bit % 8)));
    }
  }
  return Varint((groups << 1) | 1) + bits;
}

std::string LengthBytes(size_t size) {
  const auto n = static_cast<uint32_t>(size);
  std::string out(4, '\0');
  std::memcpy(out.data(), &n, 4);
  return out;
}

std::string WithLength(const std::string& bytes) { return LengthBytes(bytes.size()) + bytes; }

std::string PlainInt64(const std::vector<int64_t>& v) { return Plain(v); }
std::string PlainFloat(const std::vector<float>& v) { return Plain(v); }
std::string PlainDouble(const std::vector<double>& v) { return Plain(v); }

std::string Snappy(const std::string& raw) {
  std::string out;
  snappy::Compress(raw.data(), raw.size(), &out);
  return out;
}

std::string Page(const PageSpec& s, const std::string& payload) {
  ThriftWriter w;
  w.I32(1, static_cast<int32_t>(s.type));
  w.I32(2, s.raw_size);
  w.I32(3, static_cast<int64_t>(payload.size()));
  if (s.type == PageType::kData) {
    w.BeginStruct(5);
    w.I32(1, s.num_values), w.I32(2, static_cast<int32_t>(s.encoding));
    w.I32(3, 3), w.I32(4, 3);  // levels: RLE
    w.End();
  } else if (s.type == PageType::kDictionary) {
    w.BeginStruct(7);
    w.I32(1, s.num_values), w.I32(2, static_cast<int32_t>(Encoding::kPlain));
    w.End();
  } else {
    w.BeginStruct(8);
    w.I32(1, s.num_values), w.I32(2, s.num_nulls), w.I32(3, s.num_rows);
    w.I32(4, static_cast<int32_t>(s.encoding));
    w.I32(5, s.definition_bytes), w.I32(6, s.repetition_bytes);
    w.Bool(7, s.is_compressed);
    w.End();
  }
  w.End();
  return w.Take() + payload;
}

LeafSpec ScalarLeaf(const std::string& name, PhysicalType type, Repetition repetition) {
  SchemaElement e{name, true, type, repetition, 0};
  return {{e}, {name}, type};
}

LeafSpec ListLeaf(const std::string& name, PhysicalType type) {
  return {{{name, false, type, Repetition::kOptional, 1},
           {"list", false, type, Repetition::kRepeated, 1},
           {"element", true, type, Repetition::kOptional, 0}},
          {name, "list", "element"},
          type};
}

std::string ParquetFileBytes(
    const std::vector<LeafSpec>& leaves,
    const std::vector<std::pair<int64_t, std::vector<ChunkSpec>>>& row_groups) {
  std::string file = "PAR1";
  ThriftWriter w;
  size_t elements = 1;
  for (const auto& leaf : leaves) elements += leaf.elements.size();
  w.BeginList(2, 12, elements);
  w.ListStruct(), w.Binary(4, "schema"), w.I32(5, static_cast<int64_t>(leaves.size())), w.End();
  for (const auto& leaf : leaves) {
    for (const auto& e : leaf.elements) {
      w.ListStruct();
      if (e.has_type) w.I32(1, static_cast<int32_t>(e.type));
      w.I32(3, static_cast<int32_t>(e.repetition));
      w.Binary(4, e.name);
      if (e.num_children > 0) w.I32(5, e.num_children);
      w.End();
    }
  }
  int64_t total_rows = 0;
  for (const auto& g : row_groups) total_rows += g.first;
  w.I64(3, total_rows);
  w.BeginList(4, 12, row_groups.size());
  for (const auto& [rows, chunks] : row_groups) {
    w.ListStruct();
    w.BeginList(1, 12, chunks.size());
    for (size_t c = 0; c < chunks.size(); ++c) {
      const int64_t offset = static_cast<int64_t>(file.size());
      file += chunks[c].pages;
      w.ListStruct();
      w.I64(2, offset);
      w.BeginStruct(3);
      w.I32(1, static_cast<int32_t>(leaves[c].type));
      w.BeginList(2, 5, 1), w.ListI32(0);  // encodings: [PLAIN]
      w.BeginList(3, 8, leaves[c].path.size());
      for (const auto& p : leaves[c].path) w.ListBinary(p);
      w.I32(4, chunks[c].codec);
      w.I64(5, chunks[c].num_values);
      w.I64(6, static_cast<int64_t>(chunks[c].pages.size()));
      w.I64(7, static_cast<int64_t>(chunks[c].pages.size()));
      w.I64(9, offset);
      if (chunks[c].dictionary_first) w.I64(11, offset);
      w.End();
      w.End();
    }
    w.I64(2, 0);
    w.I64(3, rows);
    w.End();
  }
  w.Binary(6, "wmkit test writer");
  w.End();
  const std::string footer = w.Take();
  return file + footer + LengthBytes(footer.size()) + "PAR1";
}

// Optional DOUBLE with nulls [1.5, null, 2.5, 1.5, null, 2.5], dictionary-encoded, in a snappy
// data page v2 (levels uncompressed).
std::string OptionalDictionaryFile() {
  const std::string dict = PlainDouble({1.5, 2.5});
  const std::string def = BitPackedRun({1, 0, 1, 1, 0, 1}, 1);
  const std::string indices = std::string(1, '\1') + BitPackedRun({0, 1, 0, 1}, 1);
  const std::string page = Page({.type = PageType::kDataV2,
                                 .num_values = 6,
                                 .encoding = Encoding::kRleDictionary,
                                 .raw_size = static_cast<int32_t>(def.size() + indices.size()),
                                 .num_nulls = 2,
                                 .num_rows = 6,
                                 .definition_bytes = static_cast<int32_t>(def.size())},
                                def + Snappy(indices));
  ChunkSpec chunk{Page({.type = PageType::kDictionary,
                        .num_values = 2,
                        .raw_size = static_cast<int32_t>(dict.size())},
                       Snappy(dict)) +
                      page,
                  6, /*codec=*/1, /*dictionary_first=*/true};
  return ParquetFileBytes({ScalarLeaf("reward", PhysicalType::kDouble, Repetition::kOptional)},
                          {{6, {chunk}}});
}

// list<float> (pyarrow's 3 levels): [1,2,3], [], null, [4] in row group 0; [5,6] in row group 1,
// split over two v1 pages.
std::string ListColumnFile(bool null_element) {
  const std::string rep = WithLength(BitPackedRun({0, 1, 1, 0, 0, 0}, 1));
  const std::string def = WithLength(BitPackedRun({3, 3, null_element ? 2u : 3u, 1, 0, 3}, 2));
  const std::string v0 =
      PlainFloat(null_element ? std::vector<float>{1, 2, 4} : std::vector<float>{1, 2, 3, 4});
  const std::string p0 = rep + def + v0;
  ChunkSpec g0{Page({.num_values = 6, .raw_size = static_cast<int32_t>(p0.size())}, Snappy(p0)), 6,
               /*codec=*/1};
  const std::string p1 =
      WithLength(RleRun(0, 1, 1)) + WithLength(RleRun(3, 1, 2)) + PlainFloat({5});
  const std::string p2 =
      WithLength(RleRun(1, 1, 1)) + WithLength(RleRun(3, 1, 2)) + PlainFloat({6});
  ChunkSpec g1{Page({.num_values = 1, .raw_size = static_cast<int32_t>(p1.size())}, p1) +
                   Page({.num_values = 1, .raw_size = static_cast<int32_t>(p2.size())}, p2),
               2};
  return ParquetFileBytes({ListLeaf("action", PhysicalType::kFloat)}, {{4, {g0}}, {1, {g1}}});
}

}  // namespace wm::parquet::testing
