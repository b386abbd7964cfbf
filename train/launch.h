#pragma once
// Process setup for data-parallel wm-train (docs/dynamics.md, "Data parallel"). Torch-free.
#include "train/trainer.h"

namespace wm::train {

// torchrun-style: RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT (all optional; absent = one
// process), and LOCAL_RANK, which turns --device cuda into cuda:LOCAL_RANK. Throws wm::Error
// naming the variable when a value is malformed.
void ReadDistributedEnvironment(TrainOptions& options);

// Runs this executable `nproc` times with --nproc removed from argv and RANK / WORLD_SIZE /
// LOCAL_RANK / MASTER_ADDR=127.0.0.1 / MASTER_PORT (a free port) set; waits for all. When one
// rank fails the others are stopped. Returns 0 when every rank exited 0, else 1.
int SpawnLocalRanks(int nproc, int argc, char** argv);

}  // namespace wm::train
