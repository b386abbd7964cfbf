#include "trainkit/module_archive.h"

#include "core/error.h"

namespace wm::trainkit {

std::vector<std::pair<std::string, torch::Tensor>> ModuleTensors(const torch::nn::Module& m) {
  std::vector<std::pair<std::string, torch::Tensor>> out;
  for (const auto& item : m.named_parameters()) out.emplace_back(item.key(), item.value());
  for (const auto& item : m.named_buffers()) out.emplace_back(item.key(), item.value());
  return out;
}

void AddTensor(TensorArchiveWriter& w, const std::string& name, const torch::Tensor& t) {
  torch::Tensor c = t.detach().to(torch::kCPU).contiguous();
  Check(c.scalar_type() == torch::kFloat || c.scalar_type() == torch::kLong,
        "unsupported tensor type in checkpoint", {.key = name});
  w.Add(name, c.scalar_type() == torch::kFloat ? DType::kFloat32 : DType::kInt64, c.sizes().vec(),
        c.data_ptr(), c.numel() * c.element_size());
}

void LoadTensor(const TensorArchiveReader& r, const std::string& name, torch::Tensor& dst) {
  const ArchiveTensor& a = r.Get(name);
  const auto expected_type = dst.scalar_type() == torch::kFloat ? DType::kFloat32 : DType::kInt64;
  Check(a.dtype == expected_type && a.shape == dst.sizes().vec(),
        "checkpoint tensor is " + DTypeName(a.dtype) + ShapeString(a.shape) + ", model wants " +
            ShapeString(dst.sizes().vec()),
        {.file = r.path(), .key = name});
  torch::NoGradGuard no_grad;
  torch::Tensor src = torch::from_blob(const_cast<uint8_t*>(a.data), a.shape,
                                       torch::TensorOptions().dtype(dst.scalar_type()));
  dst.copy_(src);
}

void AddModule(TensorArchiveWriter& w, const std::string& prefix, const torch::nn::Module& m) {
  for (const auto& [name, t] : ModuleTensors(m)) AddTensor(w, prefix + name, t);
}

void LoadModule(const TensorArchiveReader& r, const std::string& prefix, torch::nn::Module& m) {
  for (auto& [name, t] : ModuleTensors(m)) LoadTensor(r, prefix + name, t);
}

void LoadParentModule(const Parent& parent, torch::nn::Module& m) {
  constexpr const char* kPrefix = "model/";
  try {
    size_t archived = 0;
    for (const std::string& name : parent.archive->Names()) archived += name.rfind(kPrefix, 0) == 0;
    const auto tensors = ModuleTensors(m);
    for (const auto& [name, t] : tensors) {
      Check(parent.archive->Contains(kPrefix + name), "the parent has no tensor " + name);
    }
    Check(archived == tensors.size(), "the parent has " + std::to_string(archived) +
                                          " model tensors, this model " +
                                          std::to_string(tensors.size()));
    LoadModule(*parent.archive, kPrefix, m);
  } catch (const Error& e) {
    throw ParentError(parent, e.what());
  }
}

void AddAdamW(TensorArchiveWriter& w, const AdamW& adamw) {
  const auto& params = adamw.parameters();
  for (size_t i = 0; i < params.size(); ++i) {
    AddTensor(w, "adamw/exp_avg/" + params[i].first, adamw.exp_avg()[i]);
    AddTensor(w, "adamw/exp_avg_sq/" + params[i].first, adamw.exp_avg_sq()[i]);
  }
}

void LoadAdamW(const TensorArchiveReader& r, int64_t step_count, AdamW& adamw) {
  const auto& params = adamw.parameters();
  for (size_t i = 0; i < params.size(); ++i) {
    LoadTensor(r, "adamw/exp_avg/" + params[i].first, adamw.exp_avg()[i]);
    LoadTensor(r, "adamw/exp_avg_sq/" + params[i].first, adamw.exp_avg_sq()[i]);
  }
  adamw.set_step_count(step_count);
}

}  // namespace wm::trainkit
