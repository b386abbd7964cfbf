#include "ingest/parquet/parquet_file.h"

#include <algorithm>
#include <cstring>

#include "core/error.h"
#include "core/mapped_file.h"

namespace wm::parquet {
namespace {

constexpr std::string_view kMagic = "PAR1";

// Depth-first walk of the flattened schema, collecting leaves with their level bounds.
class SchemaWalker {
 public:
  explicit SchemaWalker(const std::vector<SchemaElement>& schema) : schema_(schema) {}

  std::vector<LeafColumn> Leaves() {
    const SchemaElement& root = schema_.at(0);
    next_ = 1;
    for (int32_t i = 0; i < root.num_children; ++i) Visit("", "", 0, 0, 0);
    Check(next_ == schema_.size(), "schema has " + std::to_string(schema_.size() - next_) +
                                       " elements outside the root's children");
    return std::move(leaves_);
  }

 private:
  void Visit(const std::string& prefix, const std::string& field, int def, int rep,
             int element_def) {
    Check(next_ < schema_.size(), "schema: a group declares more children than the schema has");
    Check(++depth_ <= 16, "schema nested deeper than 16 levels");
    const SchemaElement& e = schema_[next_++];
    const std::string path = prefix.empty() ? e.name : prefix + "." + e.name;
    const std::string top = field.empty() ? e.name : field;
    if (e.repetition != Repetition::kRequired) ++def;
    if (e.repetition == Repetition::kRepeated) {
      ++rep;
      element_def = def;
    }
    if (e.num_children == 0) {
      Check(e.has_type, "schema: leaf '" + path + "' has no physical type");
      leaves_.push_back({path, top, e.type, def, rep, element_def});
    } else {
      Check(e.num_children > 0, "schema: negative num_children at '" + path + "'");
      for (int32_t i = 0; i < e.num_children; ++i) Visit(path, top, def, rep, element_def);
    }
    --depth_;
  }

  const std::vector<SchemaElement>& schema_;
  std::vector<LeafColumn> leaves_;
  size_t next_ = 0;
  int depth_ = 0;
};

}  // namespace

ParquetFile::ParquetFile(std::string name, std::unique_ptr<MappedFile> mapped, std::string owned)
    : name_(std::move(name)), mapped_(std::move(mapped)), owned_(std::move(owned)) {
  bytes_ = mapped_ ? mapped_->view() : std::string_view(owned_);
  try {
    ParseFooter();
  } catch (const Error& e) {
    throw e.WithFile(name_);
  }
}

ParquetFile::ParquetFile(const std::string& path)
    : ParquetFile(path, std::make_unique<MappedFile>(path), {}) {}

ParquetFile ParquetFile::FromBytes(std::string bytes, const std::string& name) {
  return ParquetFile(name, nullptr, std::move(bytes));
}

ParquetFile::~ParquetFile() = default;

ParquetFile::ParquetFile(ParquetFile&& o) noexcept
    : name_(std::move(o.name_)),
      mapped_(std::move(o.mapped_)),
      owned_(std::move(o.owned_)),
      meta_(std::move(o.meta_)),
      leaves_(std::move(o.leaves_)) {
  // A moved std::string may move its bytes (small-string buffer): point at the new home.
  bytes_ = mapped_ ? mapped_->view() : std::string_view(owned_);
}

void ParquetFile::ParseFooter() {
  // Layout: "PAR1" | column chunks | footer (Thrift FileMetaData) | u32 footer length | "PAR1"
  Check(bytes_.size() >= 12, "not a Parquet file: " + std::to_string(bytes_.size()) +
                                 " bytes is shorter than the 12 of an empty one");
  Check(bytes_.substr(0, 4) == kMagic && bytes_.substr(bytes_.size() - 4) == kMagic,
        "not a Parquet file: no PAR1 magic at the start and end (an encrypted 'PARE' file, or "
        "truncated?)");
  uint32_t footer_length = 0;
  std::memcpy(&footer_length, bytes_.data() + bytes_.size() - 8, 4);
  Check(footer_length <= bytes_.size() - 12,
        "footer length " + std::to_string(footer_length) + " runs past the start of the file");
  try {
    meta_ = ParseFileMetaData(bytes_.substr(bytes_.size() - 8 - footer_length, footer_length));
  } catch (const Error& e) {
    throw Error("footer: " + e.message());
  }
  leaves_ = SchemaWalker(meta_.schema).Leaves();
  int64_t rows = 0;
  for (size_t g = 0; g < meta_.row_groups.size(); ++g) {
    const RowGroup& group = meta_.row_groups[g];
    Check(group.columns.size() == leaves_.size(),
          "has " + std::to_string(group.columns.size()) + " column chunks, the schema " +
              std::to_string(leaves_.size()) + " leaves",
          {.record = static_cast<int64_t>(g), .record_label = "row group"});
    Check(group.num_rows >= 0 && !__builtin_add_overflow(rows, group.num_rows, &rows),
          "bad num_rows", {.record = static_cast<int64_t>(g), .record_label = "row group"});
  }
  Check(rows == meta_.num_rows, "row groups hold " + std::to_string(rows) +
                                    " rows, the footer says " + std::to_string(meta_.num_rows));
}

const LeafColumn* ParquetFile::Find(const std::string& name) const {
  for (const auto& leaf : leaves_) {
    if (leaf.path == name) return &leaf;
  }
  const LeafColumn* match = nullptr;
  for (const auto& leaf : leaves_) {
    if (leaf.field != name) continue;
    if (match) return nullptr;  // a struct field with several leaves: name one by its path
    match = &leaf;
  }
  return match;
}

Column ParquetFile::Read(const std::string& name) const {
  return Read(name, 0, meta_.row_groups.size());
}

int64_t ParquetFile::GroupStart(size_t g) const {
  int64_t row = 0;  // the sum cannot overflow: ParseFooter checked it
  for (size_t i = 0; i < g && i < meta_.row_groups.size(); ++i) row += meta_.row_groups[i].num_rows;
  return row;
}

Column ParquetFile::Read(const std::string& name, size_t first, size_t end) const {
  const LeafColumn* leaf = Find(name);
  if (!leaf) {
    std::string known;
    for (const auto& l : leaves_) known += (known.empty() ? "" : ", ") + l.path;
    throw Error("no column '" + name + "' (columns: " + known + ")", {.file = name_});
  }
  Check(leaf->max_repetition <= 1, "nested lists are not supported",
        {.file = name_, .key = leaf->path});
  Column out;
  out.path = leaf->path;
  out.type = leaf->type;
  end = std::min(end, meta_.row_groups.size());
  first = std::min(first, end);
  for (size_t g = first; g < end; ++g) {
    try {
      ReadChunk(*leaf, g, out);
    } catch (const Error& e) {
      throw e.WithRecord(static_cast<int64_t>(g), "row group").WithKey(leaf->path).WithFile(name_);
    }
  }
  const int64_t want = GroupStart(end) - GroupStart(first);
  Check(out.rows() == want,
        "column holds " + std::to_string(out.rows()) + " rows, its row groups " +
            std::to_string(want),
        {.file = name_, .key = leaf->path});
  return out;
}

}  // namespace wm::parquet
