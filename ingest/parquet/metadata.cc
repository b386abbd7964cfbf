#include "ingest/parquet/metadata.h"

#include "core/error.h"
#include "ingest/parquet/thrift_compact.h"

namespace wm::parquet {
namespace {
using T = ThriftType;

int32_t ReadI32(ThriftReader& r, T type) {
  int64_t v = r.ReadInt(type);
  Check(v >= INT32_MIN && v <= INT32_MAX, "Thrift: i32 field out of range");
  return static_cast<int32_t>(v);
}

// Calls read_element once per element of the list at the cursor.
template <typename F>
void ReadList(ThriftReader& r, T type, F read_element) {
  Check(type == T::kList, "Thrift: expected a list");
  ThriftList list = r.ReadListHeader();
  for (int64_t i = 0; i < list.size; ++i) read_element(list.element);
}

SchemaElement ReadSchemaElement(ThriftReader& r) {
  SchemaElement e;
  r.ReadStruct([&](int16_t id, T type) {
    if (id == 1) {
      e.has_type = true;
      e.type = static_cast<PhysicalType>(ReadI32(r, type));
    } else if (id == 3) {
      int32_t rep = ReadI32(r, type);
      Check(rep >= 0 && rep <= 2, "schema: unknown repetition type " + std::to_string(rep));
      e.repetition = static_cast<Repetition>(rep);
    } else if (id == 4) {
      e.name = r.ReadBinary();
    } else if (id == 5) {
      e.num_children = ReadI32(r, type);
    } else {
      r.Skip(type);
    }
  });
  return e;
}

void ReadColumnMetaData(ThriftReader& r, ColumnChunk& c) {
  r.ReadStruct([&](int16_t id, T type) {
    switch (id) {
      case 1:
        c.type = static_cast<PhysicalType>(ReadI32(r, type));
        break;
      case 3:
        ReadList(r, type, [&](T) { c.path.push_back(r.ReadBinary()); });
        break;
      case 4:
        c.codec = ReadI32(r, type);
        break;
      case 5:
        c.num_values = r.ReadInt(type);
        break;
      case 7:
        c.total_compressed_size = r.ReadInt(type);
        break;
      case 9:
        c.data_page_offset = r.ReadInt(type);
        break;
      case 11:
        c.dictionary_page_offset = r.ReadInt(type);
        break;
      default:
        r.Skip(type);
    }
  });
}

RowGroup ReadRowGroup(ThriftReader& r) {
  RowGroup g;
  r.ReadStruct([&](int16_t id, T type) {
    if (id == 1) {
      ReadList(r, type, [&](T) {
        ColumnChunk c;
        bool has_meta = false;
        r.ReadStruct([&](int16_t cid, T ctype) {
          if (cid == 2) {
            Check(r.ReadInt(ctype) >= 0, "column chunk: negative file_offset");
          } else if (cid == 3) {
            has_meta = true;
            ReadColumnMetaData(r, c);
          } else if (cid == 1) {
            r.ReadBinary();
            throw Error("column chunk stored in another file (file_path) is not supported");
          } else {
            r.Skip(ctype);
          }
        });
        Check(has_meta, "column chunk without meta_data");
        g.columns.push_back(std::move(c));
      });
    } else if (id == 3) {
      g.num_rows = r.ReadInt(type);
    } else {
      r.Skip(type);
    }
  });
  return g;
}

}  // namespace

std::string TypeName(PhysicalType type) {
  static const char* const kNames[] = {"BOOLEAN", "INT32",  "INT64",      "INT96",
                                       "FLOAT",   "DOUBLE", "BYTE_ARRAY", "FIXED_LEN_BYTE_ARRAY"};
  const auto i = static_cast<int32_t>(type);
  return i >= 0 && i < 8 ? kNames[i] : "type " + std::to_string(i);
}

std::string CodecName(int32_t codec) {
  static const char* const kNames[] = {"UNCOMPRESSED", "SNAPPY", "GZIP", "LZO",
                                       "BROTLI",       "LZ4",    "ZSTD", "LZ4_RAW"};
  return codec >= 0 && codec < 8 ? kNames[codec] : "codec " + std::to_string(codec);
}

std::string EncodingName(int32_t encoding) {
  static const char* const kNames[] = {
      "PLAIN",          "GROUP_VAR_INT",       "PLAIN_DICTIONARY",        "RLE",
      "BIT_PACKED",     "DELTA_BINARY_PACKED", "DELTA_LENGTH_BYTE_ARRAY", "DELTA_BYTE_ARRAY",
      "RLE_DICTIONARY", "BYTE_STREAM_SPLIT"};
  return encoding >= 0 && encoding < 10 ? kNames[encoding] : "encoding " + std::to_string(encoding);
}

FileMetaData ParseFileMetaData(std::string_view thrift) {
  ThriftReader r(thrift);
  FileMetaData m;
  r.ReadStruct([&](int16_t id, T type) {
    switch (id) {
      case 2:
        ReadList(r, type, [&](T) { m.schema.push_back(ReadSchemaElement(r)); });
        break;
      case 3:
        m.num_rows = r.ReadInt(type);
        break;
      case 4:
        ReadList(r, type, [&](T) { m.row_groups.push_back(ReadRowGroup(r)); });
        break;
      case 6:
        m.created_by = r.ReadBinary();
        break;
      default:
        r.Skip(type);
    }
  });
  Check(!m.schema.empty(), "footer has no schema");
  Check(m.num_rows >= 0, "footer: negative num_rows");
  return m;
}

PageHeader ParsePageHeader(std::string_view bytes) {
  ThriftReader r(bytes);
  PageHeader h;
  auto data_page = [&](int16_t id, T type) {
    switch (id) {
      case 1:
        h.num_values = ReadI32(r, type);
        break;
      case 2:
        h.encoding = ReadI32(r, type);
        break;
      case 3:
        h.definition_level_encoding = ReadI32(r, type);
        break;
      case 4:
        h.repetition_level_encoding = ReadI32(r, type);
        break;
      default:
        r.Skip(type);
    }
  };
  auto dictionary_page = [&](int16_t id, T type) {
    if (id == 1)
      h.num_values = ReadI32(r, type);
    else if (id == 2)
      h.encoding = ReadI32(r, type);
    else
      r.Skip(type);
  };
  auto data_page_v2 = [&](int16_t id, T type) {
    switch (id) {
      case 1:
        h.num_values = ReadI32(r, type);
        break;
      case 4:
        h.encoding = ReadI32(r, type);
        break;
      case 5:
        h.definition_levels_length = ReadI32(r, type);
        break;
      case 6:
        h.repetition_levels_length = ReadI32(r, type);
        break;
      case 7:
        h.is_compressed = r.ReadBool(type);
        break;
      default:
        r.Skip(type);
    }
  };
  r.ReadStruct([&](int16_t id, T type) {
    switch (id) {
      case 1:
        h.type = static_cast<PageType>(ReadI32(r, type));
        break;
      case 2:
        h.uncompressed_size = ReadI32(r, type);
        break;
      case 3:
        h.compressed_size = ReadI32(r, type);
        break;
      case 5:
        r.ReadStruct(data_page);
        break;
      case 7:
        r.ReadStruct(dictionary_page);
        break;
      case 8:
        r.ReadStruct(data_page_v2);
        break;
      default:
        r.Skip(type);
    }
  });
  Check(h.uncompressed_size >= 0 && h.compressed_size >= 0 && h.num_values >= 0 &&
            h.definition_levels_length >= 0 && h.repetition_levels_length >= 0,
        "page header has a negative size or count");
  h.header_size = r.position();
  return h;
}

}  // namespace wm::parquet
