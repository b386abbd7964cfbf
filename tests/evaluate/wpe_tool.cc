// wpe_tool OUT_DIR < values.csv: the WPE report of hand-given values, for test_wpe_reference.py
// to compare with SciPy. Input rows: `policy,in_distribution(0|1),true_value,wm_value` (no
// header); intervals and episode counts are 0. Writes OUT_DIR/wpe.csv and wpe_summary.json.
#include <iostream>
#include <sstream>
#include <string>

#include "evaluate/wpe_report.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: wpe_tool OUT_DIR < values.csv\n";
    return 2;
  }
  using wm::evaluate::PolicyEstimate;
  std::vector<PolicyEstimate> truth, model;
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream row(line);
    std::string name, in_dist, t, m;
    std::getline(row, name, ','), std::getline(row, in_dist, ','), std::getline(row, t, ',');
    std::getline(row, m);
    truth.push_back({name, in_dist == "1", 0, std::stod(t), 0, 0});
    model.push_back({name, in_dist == "1", 0, std::stod(m), 0, 0});
  }
  try {
    const auto rows = wm::evaluate::PairWithTruth(model, truth, "stdin");
    wm::evaluate::WriteWpeReport(argv[1], rows, wm::evaluate::SummarizeWpe(rows),
                                 nlohmann::json::object());
  } catch (const std::exception& e) {
    std::cerr << "wpe_tool: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
