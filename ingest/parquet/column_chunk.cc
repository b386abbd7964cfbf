// ParquetFile::ReadChunk: the pages of one column chunk -> values and row boundaries.
#include <snappy.h>

#include <cstring>

#include "core/error.h"
#include "core/zstd_codec.h"
#include "ingest/parquet/parquet_file.h"

namespace wm::parquet {
namespace {

// Bounds what a damaged header can make us allocate; pyarrow writes pages of ~1 MB and at most
// 20,000 rows, so this is far above any real page.
constexpr int64_t kMaxPageValues = int64_t{1} << 24;

std::string Decompress(std::string_view bytes, int32_t codec, size_t expected) {
  switch (static_cast<Codec>(codec)) {
    case Codec::kUncompressed:
      Check(bytes.size() == expected, "uncompressed page of " + std::to_string(bytes.size()) +
                                          " bytes, the header says " + std::to_string(expected));
      return std::string(bytes);
    case Codec::kSnappy: {
      size_t length = 0;
      Check(
          snappy::GetUncompressedLength(bytes.data(), bytes.size(), &length) && length == expected,
          "snappy data does not decompress to the header's " + std::to_string(expected) + " bytes");
      std::string out(length, '\0');
      Check(snappy::RawUncompress(bytes.data(), bytes.size(), out.data()), "corrupt snappy data");
      return out;
    }
    case Codec::kZstd:
      return ZstdDecompress(bytes, expected);
    default:
      break;
  }
  throw Error("compression codec " + CodecName(codec) +
              " is not supported (UNCOMPRESSED, SNAPPY, ZSTD are)");
}

// One data page's levels, decoded: num_values entries each (empty when the max level is 0).
struct Levels {
  std::vector<uint32_t> repetition, definition;
};

// v1 levels: each present kind is a u32 byte length then RLE runs. Returns the bytes consumed.
size_t ReadLevelsV1(std::string_view page, const LeafColumn& leaf, const PageHeader& h,
                    Levels& out) {
  size_t pos = 0;
  auto read = [&](int max_level, int32_t encoding, std::vector<uint32_t>& levels) {
    if (max_level == 0) return;
    Check(encoding == static_cast<int32_t>(Encoding::kRle),
          "level encoding " + EncodingName(encoding) + " is not supported (RLE is)");
    Check(page.size() - pos >= 4, "level length truncated");
    uint32_t length = 0;
    std::memcpy(&length, page.data() + pos, 4);
    pos += 4;
    Check(length <= page.size() - pos, "levels run past the page");
    levels = DecodeRleHybrid(page.substr(pos, length), BitWidth(max_level), h.num_values);
    pos += length;
  };
  read(leaf.max_repetition, h.repetition_level_encoding, out.repetition);
  read(leaf.max_definition, h.definition_level_encoding, out.definition);
  return pos;
}

// Decodes `present` values of a page (PLAIN, dictionary indices, or RLE booleans).
void DecodeValues(std::string_view data, const LeafColumn& leaf, int32_t encoding, int64_t present,
                  const Values* dictionary, Values& out) {
  switch (static_cast<Encoding>(encoding)) {
    case Encoding::kPlain:
      DecodePlain(data, leaf.type, present, out);
      return;
    case Encoding::kPlainDictionary:
    case Encoding::kRleDictionary: {
      Check(dictionary != nullptr, "dictionary-encoded page without a dictionary page");
      Check(!data.empty(), "dictionary indices without a bit width");
      const int width = static_cast<uint8_t>(data[0]);
      AppendFromDictionary(*dictionary, DecodeRleHybrid(data.substr(1), width, present), out);
      return;
    }
    case Encoding::kRle: {
      Check(leaf.type == PhysicalType::kBoolean, "RLE values are only defined for BOOLEAN");
      Check(data.size() >= 4, "RLE booleans without their length");
      uint32_t length = 0;
      std::memcpy(&length, data.data(), 4);
      Check(length <= data.size() - 4, "RLE booleans run past the page");
      for (uint32_t v : DecodeRleHybrid(data.substr(4, length), 1, present)) out.ints.push_back(v);
      return;
    }
    default:
      break;
  }
  throw Error("value encoding " + EncodingName(encoding) +
              " is not supported (PLAIN, PLAIN_DICTIONARY, RLE_DICTIONARY are)");
}

// Counts the entries that carry a value, and checks list structure, before values are decoded.
int64_t PresentValues(const Levels& levels, const LeafColumn& leaf, int64_t num_values) {
  if (leaf.max_definition == 0) return num_values;
  int64_t present = 0;
  for (int64_t i = 0; i < num_values; ++i) {
    const uint32_t def = levels.definition[i];
    Check(def <= static_cast<uint32_t>(leaf.max_definition),
          "definition level " + std::to_string(def) + " above the column's maximum " +
              std::to_string(leaf.max_definition));
    if (def == static_cast<uint32_t>(leaf.max_definition))
      ++present;
    else if (leaf.max_repetition > 0 && def >= static_cast<uint32_t>(leaf.element_definition)) {
      throw Error("null element inside a list (entry " + std::to_string(i) + ") is not supported");
    }
  }
  return present;
}

// Row boundaries from repetition levels: a new row starts at every repetition level 0 (rows may
// continue across v1 pages). row_starts' last entry is always the values decoded so far.
void AppendRows(const Levels& levels, const LeafColumn& leaf, int64_t num_values, Column& out) {
  for (int64_t i = 0; i < num_values; ++i) {
    if (leaf.max_repetition == 0 || levels.repetition[i] == 0) {
      out.row_starts.push_back(out.row_starts.back());
    } else {
      Check(out.rows() > 0, "the first entry continues a row (repetition level > 0)");
    }
    if (leaf.max_definition == 0 ||
        levels.definition[i] == static_cast<uint32_t>(leaf.max_definition)) {
      ++out.row_starts.back();
    }
  }
}

}  // namespace

void ParquetFile::ReadChunk(const LeafColumn& leaf, size_t row_group, Column& out) const {
  const ColumnChunk& chunk = meta_.row_groups[row_group].columns.at(&leaf - leaves_.data());
  Check(chunk.type == leaf.type, "column chunk type " + TypeName(chunk.type) +
                                     " differs from the schema's " + TypeName(leaf.type));
  int64_t start = chunk.data_page_offset;
  if (chunk.dictionary_page_offset > 0 && chunk.dictionary_page_offset < start) {
    start = chunk.dictionary_page_offset;
  }
  Check(start >= 4 && chunk.total_compressed_size >= 0 &&
            static_cast<uint64_t>(start) <= bytes_.size() &&
            static_cast<uint64_t>(chunk.total_compressed_size) <= bytes_.size() - start,
        "column chunk at offset " + std::to_string(start) + " (+" +
            std::to_string(chunk.total_compressed_size) + " bytes) lies outside the file");
  std::string_view rest = bytes_.substr(start, chunk.total_compressed_size);
  Values dictionary;
  bool has_dictionary = false;
  int64_t seen = 0;
  for (int page = 0; seen < chunk.num_values; ++page) {
    try {
      Check(!rest.empty(), "column chunk ends after " + std::to_string(seen) + " of " +
                               std::to_string(chunk.num_values) + " values");
      const PageHeader h = ParsePageHeader(rest);
      rest.remove_prefix(h.header_size);
      Check(static_cast<size_t>(h.compressed_size) <= rest.size(),
            "page of " + std::to_string(h.compressed_size) + " bytes runs past the column chunk");
      std::string_view payload = rest.substr(0, h.compressed_size);
      rest.remove_prefix(h.compressed_size);
      if (h.type == PageType::kIndex) continue;
      Check(h.num_values <= kMaxPageValues, "page claims " + std::to_string(h.num_values) +
                                                " values, more than any real writer puts in one");
      if (h.type == PageType::kDictionary) {
        Check(!has_dictionary, "second dictionary page in one column chunk");
        std::string raw = Decompress(payload, chunk.codec, h.uncompressed_size);
        DecodePlain(raw, leaf.type, h.num_values, dictionary);
        has_dictionary = true;
        continue;
      }
      Levels levels;
      std::string raw;
      std::string_view values;
      if (h.type == PageType::kData) {
        raw = Decompress(payload, chunk.codec, h.uncompressed_size);
        values = std::string_view(raw).substr(ReadLevelsV1(raw, leaf, h, levels));
      } else {
        Check(h.type == PageType::kDataV2,
              "unknown page type " + std::to_string(static_cast<int>(h.type)));
        const size_t level_bytes =
            static_cast<size_t>(h.repetition_levels_length) + h.definition_levels_length;
        Check(level_bytes <= payload.size() && level_bytes <= size_t(h.uncompressed_size),
              "v2 levels run past the page");
        if (leaf.max_repetition > 0) {
          levels.repetition = DecodeRleHybrid(payload.substr(0, h.repetition_levels_length),
                                              BitWidth(leaf.max_repetition), h.num_values);
        }
        if (leaf.max_definition > 0) {
          levels.definition = DecodeRleHybrid(
              payload.substr(h.repetition_levels_length, h.definition_levels_length),
              BitWidth(leaf.max_definition), h.num_values);
        }
        payload.remove_prefix(level_bytes);
        const size_t expected = h.uncompressed_size - level_bytes;
        raw = h.is_compressed ? Decompress(payload, chunk.codec, expected)
                              : Decompress(payload, 0, expected);
        values = raw;
      }
      const int64_t present = PresentValues(levels, leaf, h.num_values);
      const size_t before = out.values.size();
      DecodeValues(values, leaf, h.encoding, present, has_dictionary ? &dictionary : nullptr,
                   out.values);
      Check(out.values.size() - before == static_cast<size_t>(present), "decoded value count");
      AppendRows(levels, leaf, h.num_values, out);
      seen += h.num_values;
    } catch (const Error& e) {
      throw Error("page " + std::to_string(page) + ": " + e.message(), e.context());
    }
  }
}

}  // namespace wm::parquet
