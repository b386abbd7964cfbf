#pragma once
// Dataset mixtures (configs/mixtures/*.yaml): how often each dataset is drawn when several are
// trained on together, as in Octo/OXE mixtures; both trainers read them. Format
// (docs/tokenizer.md, "Data"):
//   datasets:
//     - name: fractal20220817_data   # index.json "dataset"
//       weight: 0.6                   # relative; normalised over the datasets given with --data
#include <map>
#include <string>
#include <vector>

namespace wm::trainkit {

// name -> weight (> 0). Throws wm::Error naming the file and key on a malformed file.
std::map<std::string, double> LoadMixture(const std::string& path);

// Weights for `dataset_names` (the --data datasets, in order) from `mixture`; a name missing
// from the mixture is an error naming `mixture_file`. Empty mixture -> `fallback` (e.g. the
// datasets' step counts, i.e. every frame equally likely).
std::vector<double> MixtureWeights(const std::map<std::string, double>& mixture,
                                   const std::string& mixture_file,
                                   const std::vector<std::string>& dataset_names,
                                   const std::vector<double>& fallback);

}  // namespace wm::trainkit
