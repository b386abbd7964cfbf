#include "core/checkpoint_safetensors.h"

#include <map>
#include <optional>
#include <set>
#include <vector>

#include "core/error.h"
#include "core/paths.h"
#include "core/safetensors.h"
#include "core/tensor_archive.h"

namespace wm {
namespace {

// The safetensors name of an archive tensor, or nothing when the export leaves it out.
std::optional<std::string> ExportedName(const std::string& archive_name, bool all_tensors) {
  if (all_tensors) return archive_name;
  const std::string prefix = kModelTensorPrefix;
  if (archive_name.compare(0, prefix.size(), prefix) != 0) return std::nullopt;
  return archive_name.substr(prefix.size());
}

// archive name -> safetensors name, for the tensors an export with `all_tensors` holds.
std::map<std::string, std::string> ExportedNames(const TensorArchiveReader& archive,
                                                 bool all_tensors) {
  std::map<std::string, std::string> out;
  for (const std::string& name : archive.Names()) {
    if (auto exported = ExportedName(name, all_tensors)) out[name] = *exported;
  }
  Check(!out.empty(),
        std::string("the checkpoint has no ") + (all_tensors ? "tensors" : "model/ tensors"),
        {.file = archive.path()});
  return out;
}

std::string_view BytesOf(const ArchiveTensor& t) {
  return {reinterpret_cast<const char*>(t.data), t.length};
}

// The file must hold exactly the tensors `like` would export, each with its dtype and shape.
void CheckSameTensors(const std::map<std::string, std::string>& wanted,
                      const TensorArchiveReader& like, const SafetensorsReader& file) {
  const auto& tensors = file.contents().tensors;
  for (const auto& [archive_name, name] : wanted) {
    const ErrorContext context{.file = file.path(), .key = name};
    const ArchiveTensor& want = like.Get(archive_name);
    const auto it = tensors.find(name);
    Check(it != tensors.end(),
          "missing tensor (" + like.path() + " has " + SafetensorsDTypeCode(want.dtype) + " " +
              ShapeString(want.shape) + ")",
          context);
    Check(it->second.dtype == want.dtype,
          "dtype " + SafetensorsDTypeCode(it->second.dtype) + ", expected " +
              SafetensorsDTypeCode(want.dtype),
          context);
    Check(it->second.shape == want.shape,
          "shape " + ShapeString(it->second.shape) + ", expected " + ShapeString(want.shape),
          context);
  }
  if (tensors.size() == wanted.size()) return;
  std::set<std::string> known;
  for (const auto& [archive_name, name] : wanted) known.insert(name);
  for (const auto& [name, t] : tensors) {
    Check(known.count(name) > 0,
          "tensor is not in " + like.path() + "'s exported set" +
              " (an `export --all` file needs `import --all`)",
          {.file = file.path(), .key = name});
  }
}

}  // namespace

size_t ExportCheckpointSafetensors(const SafetensorsExportOptions& options) {
  const TensorArchiveReader archive(CheckpointFileIn(options.checkpoint));
  std::vector<SafetensorsTensor> tensors;
  for (const auto& [archive_name, name] : ExportedNames(archive, options.all_tensors)) {
    const ArchiveTensor& t = archive.Get(archive_name);
    tensors.push_back({.name = name, .dtype = t.dtype, .shape = t.shape, .bytes = BytesOf(t)});
  }
  const std::map<std::string, std::string> metadata = {
      {"format", "pt"},  // what Hugging Face loaders expect of a PyTorch state_dict file
      {kSafetensorsWmkitMetaKey, archive.meta().dump()},
      {kSafetensorsWmkitTensorsKey, options.all_tensors ? "all" : "model"}};
  WriteSafetensors(options.out, tensors, metadata);
  return tensors.size();
}

size_t ImportCheckpointSafetensors(const SafetensorsImportOptions& options) {
  const TensorArchiveReader like(CheckpointFileIn(options.like));
  const SafetensorsReader file(options.safetensors);
  const auto& metadata = file.contents().metadata;
  const auto written = metadata.find(kSafetensorsWmkitTensorsKey);
  Check(written == metadata.end() || (written->second == "all") == options.all_tensors,
        "written by `export" + std::string(options.all_tensors ? "" : " --all") +
            "`: import it with" + (options.all_tensors ? "out" : "") + " --all",
        {.file = file.path()});
  const auto wanted = ExportedNames(like, options.all_tensors);
  CheckSameTensors(wanted, like, file);
  TensorArchiveWriter writer;
  for (const std::string& archive_name : like.Names()) {
    const ArchiveTensor& kept = like.Get(archive_name);
    const auto replaced = wanted.find(archive_name);
    const std::string_view bytes = replaced == wanted.end()
                                       ? BytesOf(kept)
                                       : file.contents().tensors.at(replaced->second).bytes;
    writer.Add(archive_name, kept.dtype, kept.shape, bytes.data(), bytes.size());
  }
  writer.SetMeta(like.meta());
  writer.Write(options.out);
  return wanted.size();
}

}  // namespace wm
