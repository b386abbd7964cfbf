#pragma once
// LibTorch modules <-> the wmkit tensor archive (core/tensor_archive.h): named float32/int64
// tensors, byte-reproducible, instead of torch::save (docs/tokenizer.md says why). Internal
// header (includes torch); shared by the tokenizer and the dynamics model.
#include <torch/torch.h>

#include <string>
#include <utility>
#include <vector>

#include "core/tensor_archive.h"
#include "trainkit/adamw.h"
#include "trainkit/init_from.h"

namespace wm::trainkit {

// Parameters, then buffers, by module path ("encoder.0.weight"), in registration order.
std::vector<std::pair<std::string, torch::Tensor>> ModuleTensors(const torch::nn::Module& module);

// Copies a float32 or int64 tensor (any device) into the archive under `name`.
void AddTensor(TensorArchiveWriter& writer, const std::string& name, const torch::Tensor& t);

// Copies archive tensor `name` into `dst` (same dtype and shape, else wm::Error naming the
// file, the tensor and both shapes).
void LoadTensor(const TensorArchiveReader& reader, const std::string& name, torch::Tensor& dst);

// Every ModuleTensors entry as `prefix + path`.
void AddModule(TensorArchiveWriter& writer, const std::string& prefix,
               const torch::nn::Module& module);
void LoadModule(const TensorArchiveReader& reader, const std::string& prefix,
                torch::nn::Module& module);

// --init-from: the parent's "model/" tensors into `module`, which must be exactly the parent's
// set (a tensor either side lacks, or another dtype or shape, is an error naming it).
void LoadParentModule(const Parent& parent, torch::nn::Module& module);

// The optimizer's moments as "adamw/exp_avg/<param>" and "adamw/exp_avg_sq/<param>", one
// parameter after the other. LoadAdamW also restores the step count (`step_count`, from the
// archive's meta).
void AddAdamW(TensorArchiveWriter& writer, const AdamW& adamw);
void LoadAdamW(const TensorArchiveReader& reader, int64_t step_count, AdamW& adamw);

}  // namespace wm::trainkit
