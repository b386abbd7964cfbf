// The training substrate on its own: AdamW equals torch.optim.AdamW, mixture files, the run
// directory (refuses to overwrite, writes the archive before its manifest) and step logs.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/tensorboard_events.h"
#include "core/tfrecord_frame.h"
#include "tests/core/test_util.h"
#include "trainkit/adamw.h"
#include "trainkit/checkpoint_kind.h"
#include "trainkit/mixture.h"
#include "trainkit/phase_timer.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"
#include "trainkit/training_loop.h"

namespace wm::trainkit {
namespace {
namespace fs = std::filesystem;

TEST(AdamW, MatchesLibTorchAdamW) {
  torch::manual_seed(3);
  torch::Tensor init = torch::randn({4, 3});
  torch::Tensor a = init.clone().requires_grad_(true), b = init.clone().requires_grad_(true);
  AdamW ours({{"w", a}}, {.lr = 0.01, .beta1 = 0.9, .beta2 = 0.9, .weight_decay = 0.1});
  torch::optim::AdamW ref({b},
                          torch::optim::AdamWOptions(0.01).betas({0.9, 0.9}).weight_decay(0.1));
  for (int step = 0; step < 5; ++step) {
    ours.ZeroGrad();
    ref.zero_grad();
    (a * a * (step + 1)).sum().backward();
    (b * b * (step + 1)).sum().backward();
    ours.Step();
    ref.step();
  }
  EXPECT_TRUE(torch::allclose(a, b, 1e-6, 1e-7)) << (a - b).abs().max().item<float>();
}

// The kernel's list of what this process mapped, an independent record of the BLAS loaded.
std::string MappedFiles() {
  std::ifstream maps("/proc/self/maps");
  return {std::istreambuf_iterator<char>(maps), std::istreambuf_iterator<char>()};
}

TEST(BlasLibrary, NamesTheBlasThisProcessLoaded) {
  torch::mm(torch::ones({64, 64}), torch::ones({64, 64}));  // a GEMM through LibTorch's BLAS
  const std::string blas = BlasLibrary(), mapped = MappedFiles();
  ASSERT_FALSE(blas.empty());
  if (blas.rfind("OpenBLAS ", 0) == 0) {
    EXPECT_NE(mapped.find("libopenblas"), std::string::npos) << blas;
  } else if (blas != "none loaded") {
    EXPECT_EQ(blas.front(), '/') << blas;
    EXPECT_NE(mapped.find(blas), std::string::npos) << blas << " is not mapped";
  } else {
    EXPECT_EQ(mapped.find("/libblas.so"), std::string::npos) << "a libblas is mapped";
  }
  EXPECT_EQ(TorchLibraryVersions().at("blas"), blas);
  EXPECT_EQ(TorchLibraryVersions().at("libtorch"), TorchVersion());
}

TEST(PhaseTimer, ChargesEachPhaseItsOwnTimeAndIsOffUnlessAskedFor) {
  using std::chrono::milliseconds;
  unsetenv("WM_STEP_TIMES");
  trainkit::PhaseTimer off(/*cuda=*/false);
  off.StartStep();
  off.Mark("batch");
  EXPECT_FALSE(off.enabled());
  EXPECT_EQ(off.Summary(), "");
  setenv("WM_STEP_TIMES", "1", 1);
  trainkit::PhaseTimer timer(/*cuda=*/false);
  unsetenv("WM_STEP_TIMES");
  ASSERT_TRUE(timer.enabled());
  for (int step = 0; step < 2; ++step) {
    timer.StartStep();
    std::this_thread::sleep_for(milliseconds(5));
    timer.Mark("batch");
    std::this_thread::sleep_for(milliseconds(200));
    timer.Mark("forward");
  }
  const std::string s = timer.Summary();
  // "batch 5.xx ms (2%), forward 200.xx ms (98%) per step over 2 steps"
  EXPECT_EQ(s.find("batch "), 0u) << s;
  EXPECT_NE(s.find(", forward "), std::string::npos) << s;
  EXPECT_NE(s.find("per step over 2 steps"), std::string::npos) << s;
  const double batch_ms = std::stod(s.substr(6)),
               forward_ms = std::stod(s.substr(s.find(", forward ") + 10));
  EXPECT_GE(batch_ms, 5.0);
  EXPECT_GE(forward_ms, 200.0);
  EXPECT_LT(batch_ms, forward_ms);  // each phase its own time, not the step's so far
}

TEST(Mixture, WeightsComeFromTheFileAndMisspeltKeysAreErrors) {
  test::TempDir dir_;
  const std::string mix = dir_ / "mix.yaml";
  WriteFileAtomically(mix, "datasets:\n  - name: shapes\n    weight: 2\n");
  EXPECT_EQ(MixtureWeights(LoadMixture(mix), mix, {"shapes"}, {18.0}), std::vector<double>{2.0});
  EXPECT_NE(test::ErrorText([&] {
              MixtureWeights(LoadMixture(mix), mix, {"second"}, {1.0});
            }).find("'second' (given with --data) has no weight"),
            std::string::npos);
  WriteFileAtomically(mix, "datasets:\n  - name: shapes\n    weight: -1\n");
  EXPECT_NE(test::ErrorText([&] { LoadMixture(mix); }).find("datasets[0].weight"),
            std::string::npos);
  // Misspelt keys are errors, not silently ignored.
  WriteFileAtomically(mix, "datasets:\n  - name: shapes\n    weight: 1\n    wieght: 3\n");
  EXPECT_NE(test::ErrorText([&] { LoadMixture(mix); }).find("key 'datasets[0].wieght'"),
            std::string::npos);
  WriteFileAtomically(mix, "datasets:\n  - name: shapes\n    weight: 1\ndataset: [x]\n");
  EXPECT_NE(test::ErrorText([&] { LoadMixture(mix); }).find("key 'dataset'"), std::string::npos);
}

TEST(Schedule, WarmsUpLinearlyThenFollowsACosineToMinLr) {
  const LrSchedule t{.max_lr = 1.0, .min_lr = 0.1, .warmup_steps = 10, .steps = 110};
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 0), 0.1);
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 9), 1.0);
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 10), 1.0);
  EXPECT_NEAR(LearningRateAt(t, 60), 0.55, 1e-12);
  EXPECT_NEAR(LearningRateAt(t, 110), 0.1, 1e-12);
}

TEST(StepLog, ResumingDropsTheRowsAfterTheCheckpointStep) {
  test::TempDir dir;
  const std::string path = dir / "metrics.csv";
  {
    StepLog log(path, "step,loss", 0);
    for (int step = 1; step <= 4; ++step) log.Append(std::to_string(step) + ",0.5");
  }
  StepLog resumed(path, "step,loss", 2);
  EXPECT_EQ(ReadFile(path), "step,loss\n1,0.5\n2,0.5\n");
  resumed.Append("3,0.25");
  EXPECT_EQ(ReadFile(path), "step,loss\n1,0.5\n2,0.5\n3,0.25\n");
}

// The event file beside the log is rewritten from the kept rows on resume and grows with each row
// (its contents are checked by tests/train/test_event_files.py with an independent reader).
TEST(StepLog, MirrorsRowsIntoAnEventFileBesideIt) {
  test::TempDir dir;
  const std::string events = dir / "events.out.tfevents.val";
  EXPECT_EQ(EventFileFor(dir / "val.csv"), events);
  uint64_t after_two_rows = 0;
  {
    StepLog log(dir / "val.csv", "step,psnr,ssim", 0);
    log.Append("1,20.5,0.5");
    log.Append("2,21,");
    after_two_rows = fs::file_size(events);
    log.Append("3,22,0.7");
  }
  StepLog resumed(dir / "val.csv", "step,psnr,ssim", 2);
  EXPECT_EQ(fs::file_size(events), after_two_rows) << "rows after step 2 dropped";
  resumed.Append("3,22,0.7");
  EXPECT_GT(fs::file_size(events), after_two_rows);
}

// The steps of an event file's events after its file_version event.
std::vector<int64_t> EventSteps(const std::string& path) {
  const std::string bytes = ReadFile(path);
  const std::vector<std::string_view> records = UnframeTfRecords(bytes);
  std::vector<int64_t> steps;
  for (size_t i = 1; i < records.size(); ++i) steps.push_back(DecodeEventStep(records[i]));
  return steps;
}

TEST(ImageLog, KeepsTheImagesUpToTheResumeStepAndDropsACutRecord) {
  test::TempDir dir;
  const ImageSummary image{"val/reconstructions", 1, 1, 3, "not a real png"};
  {
    ImageLog log(dir.path().string(), "val_images", 0);
    EXPECT_EQ(log.path(), dir / "events.out.tfevents.val_images");
    for (int64_t step : {100, 200, 300}) log.Append(step, image);
  }
  EXPECT_EQ(EventSteps(dir / "events.out.tfevents.val_images"),
            (std::vector<int64_t>{100, 200, 300}));
  ImageLog resumed(dir.path().string(), "val_images",
                   200);  // the checkpoint at 200: 300's image is redone
  EXPECT_EQ(EventSteps(resumed.path()), (std::vector<int64_t>{100, 200}));
  resumed.Append(300, image);
  fs::resize_file(resumed.path(), fs::file_size(resumed.path()) - 3);  // killed mid-append
  EXPECT_EQ(EventSteps(ImageLog(dir.path().string(), "val_images", 1000).path()),
            (std::vector<int64_t>{100, 200}));
}

TEST(CheckpointKind, ChecksTheKindAndNamesTheFileInEveryError) {
  test::TempDir dir;
  TensorArchiveWriter archive;
  archive.SetMeta({{"model_kind", "motion"}, {"step", 7}});
  archive.Write(dir / "checkpoint.wmt");
  EXPECT_TRUE(IsCheckpointOfKind(dir.path().string(), "motion"));  // a RUN_DIR
  EXPECT_FALSE(IsCheckpointOfKind(dir / "checkpoint.wmt", "success"));
  EXPECT_FALSE(IsCheckpointOfKind(dir / "missing", "motion"));
  int64_t step = 0;
  LoadCheckpointOfKind(dir / "checkpoint.wmt", "motion", "not motion",
                       [&](const TensorArchiveReader&, const nlohmann::json& meta) {
                         step = meta.at("step").get<int64_t>();
                       });
  EXPECT_EQ(step, 7);
  const auto load = [&](const std::string& kind, const char* key) {
    return test::ErrorText([&] {
      LoadCheckpointOfKind(dir / "checkpoint.wmt", kind, "not a " + kind + " checkpoint",
                           [&](const TensorArchiveReader&, const nlohmann::json& meta) {
                             (void)meta.at(key).get<int64_t>();
                           });
    });
  };
  const std::string wrong_kind = load("success", "step");
  EXPECT_NE(wrong_kind.find("not a success checkpoint"), std::string::npos) << wrong_kind;
  EXPECT_NE(wrong_kind.find("model_kind"), std::string::npos) << wrong_kind;
  EXPECT_NE(wrong_kind.find("checkpoint.wmt"), std::string::npos) << wrong_kind;
  const std::string missing_key = load("motion", "config");
  EXPECT_NE(missing_key.find("bad checkpoint meta"), std::string::npos) << missing_key;
  EXPECT_NE(missing_key.find("checkpoint.wmt"), std::string::npos) << missing_key;
}

TEST(RunDir, WritesTheArchiveBeforeItsManifestAndRefusesToOverwriteIt) {
  test::TempDir dir;
  const RunDir run(dir / "run", /*resume=*/false, /*create=*/true);
  EXPECT_FALSE(run.resuming());
  TensorArchiveWriter archive;
  archive.SetMeta({{"step", 3}});
  bool archive_first = false;
  run.WriteCheckpoint(archive, [&] {
    archive_first = fs::exists(run.checkpoint());
    return run.Manifest("test", {{"a", 1}}, 3);
  });
  EXPECT_TRUE(archive_first);
  const nlohmann::json manifest = nlohmann::json::parse(ReadFile(run.File(kManifestFile)));
  EXPECT_EQ(manifest.at("step"), 3);
  EXPECT_EQ(manifest.at("checkpoint").at("file"), kCheckpointFile);
  EXPECT_NE(test::ErrorText([&] { RunDir(dir / "run", false, true); }).find("pass --resume"),
            std::string::npos);
  EXPECT_TRUE(RunDir(dir / "run", /*resume=*/true, /*create=*/false).resuming());
  EXPECT_FALSE(RunDir(dir / "other", /*resume=*/true, /*create=*/false).resuming());
}

// Records what the loop asks of it; rows carry the step so the log shows which steps logged.
class RecordingStage : public TrainingStage {
 public:
  void Train(int64_t step, int64_t) override { trained.push_back(step); }
  int64_t UnitsPerStep() const override { return 4; }
  std::optional<MetricsRow> Finish(const StepInfo& info) override {
    if (info.first) firsts.push_back(info.step);
    if (!info.log_row) return std::nullopt;
    return MetricsRow{.before = "x" + std::to_string(info.step), .after = ",end"};
  }
  void SaveCheckpoint(int64_t step) override { checkpoints.push_back(step); }
  std::vector<int64_t> trained, firsts, checkpoints;
};

TEST(TrainingLoop, RowsAndCheckpointsDependOnlyOnTheStep) {
  test::TempDir dir;
  const LoopOptions o{
      .start_step = 2, .steps = 7, .max_steps_this_run = 4, .log_every = 3, .checkpoint_every = 5};
  RecordingStage stage;
  StepLog log(dir / "metrics.csv", "step,x,rate,end", 2);
  EXPECT_EQ(RunTrainingLoop(o, stage, &log), 6);  // stops early, after 4 steps
  EXPECT_EQ(stage.trained, (std::vector<int64_t>{2, 3, 4, 5}));
  EXPECT_EQ(stage.firsts, std::vector<int64_t>{3});
  EXPECT_EQ(stage.checkpoints, (std::vector<int64_t>{5, 6}));  // every 5 and the last
  const std::string rows = ReadFile(dir / "metrics.csv");
  EXPECT_EQ(rows.substr(0, rows.find('\n')), "step,x,rate,end");
  EXPECT_NE(rows.find("\n3,x3,"), std::string::npos);
  EXPECT_NE(rows.find("\n6,x6,"), std::string::npos);
  EXPECT_EQ(rows.find("\n4,"), std::string::npos);
  RecordingStage rest;
  EXPECT_EQ(RunTrainingLoop({.start_step = 6, .steps = 7, .writer = false}, rest, nullptr), 7);
  EXPECT_TRUE(rest.checkpoints.empty());  // a non-writing rank trains but saves nothing
}

}  // namespace
}  // namespace wm::trainkit
