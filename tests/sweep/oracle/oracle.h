#pragma once
// The fragility oracle's files (tests/sweep/oracle/): the data set and the
// fit scipy made of it (fit_lognormal.py), read for the C++ tests.

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "sweep/fragility.h"

namespace rocklab::test {

struct FragilityOracle {
  std::vector<sweep::FragilityPoint> points;  ///< fragility_data.csv
  double median_g{}, beta{}, log_likelihood{};
  double newton_step_ln_theta{}, newton_step_ln_beta{};  ///< scipy's distance to the maximiser
};

// The non-comment rows after the header of a CSV file.
inline std::vector<std::vector<double>> OracleRows(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<std::vector<double>> rows;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

inline FragilityOracle ReadFragilityOracle() {
  FragilityOracle o;
  for (const auto& r : OracleRows(std::string(ROCKLAB_FRAGILITY_ORACLE_DIR) + "/fragility_data.csv")) {
    o.points.push_back({r.at(0), r.at(1), r.at(2)});
  }
  const auto fit = OracleRows(std::string(ROCKLAB_FRAGILITY_ORACLE_DIR) + "/fragility_oracle.csv").at(0);
  o.median_g = fit.at(0);
  o.beta = fit.at(1);
  o.log_likelihood = fit.at(2);
  o.newton_step_ln_theta = fit.at(4);
  o.newton_step_ln_beta = fit.at(5);
  return o;
}

}  // namespace rocklab::test
