#pragma once
// Helpers shared by the daq tests: paths, scratch files, a sink that keeps
// every output, and frames generated through the rig simulator.

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/rig_simulator.h"
#include "daq/source.h"
#include "tests/scratch.h"

namespace rocklab::daq::test {

inline std::string LabRigPath() { return std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml"; }

/// The daq tests' scratch folder (tests/scratch.h: unique to the build tree
/// and the process).
inline std::string ScratchDir() { return rocklab::test::ScratchDir("daq"); }

inline std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = ScratchDir() + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// A CSV read as numbers (a text field reads as 0), its header by name.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  std::size_t Col(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
};

inline Csv ReadCsv(const std::string& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::stringstream h(line);
  for (std::string f; std::getline(h, f, ',');) csv.header.push_back(f);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream s(line);
    for (std::string f; std::getline(s, f, ',');) row.push_back(std::strtod(f.c_str(), nullptr));
    csv.rows.push_back(row);
  }
  return csv;
}

struct CollectSink : ProcessorSink {
  std::vector<BlockState> block;
  std::vector<TableState> table;
  std::vector<DaqEvent> events;
  std::vector<Problem> problems;
  std::vector<std::string> problem_text;
  void OnBlockState(const BlockState& s) override { block.push_back(s); }
  void OnTableState(const TableState& s) override { table.push_back(s); }
  void OnEvent(const DaqEvent& e) override { events.push_back(e); }
  void OnProblem(const Problem& p) override {
    problems.push_back(p);
    problem_text.push_back(ToString(p));
  }
  int CountEvents(int8_t kind) const {
    int n = 0;
    for (const auto& e : events) n += e.kind == kind;
    return n;
  }
};

/// Frames of `duration_s` at the rig rate from `motion(t)` through the simulator.
inline std::vector<Frame> SimulateFrames(const RigConfig& rig, const SimulatorNoise& noise,
                                         uint64_t seed, double duration_s,
                                         const std::function<TrueMotion(double)>& motion) {
  RigSimulator sim(rig, noise, seed);
  std::vector<Frame> frames;
  const auto n = static_cast<int64_t>(duration_s * rig.sample_rate_hz);
  for (int64_t k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rig.sample_rate_hz;
    Frame f;
    f.seq = k;
    f.time_s = t;
    f.line = k + 2;
    if (sim.Raw(motion(t), f.values)) frames.push_back(std::move(f));
  }
  return frames;
}

/// What a source gives when read to its end: its frames, the problems it
/// reported (as text), its stats, channel names and rate, and the status
/// that ended the read (kEnd, or kError with source->error() in `error`).
struct SourceRead {
  std::vector<Frame> frames;
  std::vector<std::string> problems;
  SourceStats stats;
  std::vector<std::string> names;
  double rate_hz{};
  ReadStatus status{ReadStatus::kEnd};
  std::string error;
};

/// Opens `path` with `options` (its on_problem is replaced) and reads it to
/// the end. @throws what OpenSource throws (start-up errors).
inline SourceRead ReadSource(const std::string& path, SourceOptions options) {
  SourceRead r;
  options.on_problem = [&r](const Problem& p) { r.problems.push_back(ToString(p)); };
  auto source = OpenSource(path, options);
  r.names = source->channel_names();
  r.rate_hz = source->sample_rate_hz();
  Frame f;
  while ((r.status = source->Next(f)) == ReadStatus::kFrame) r.frames.push_back(f);
  r.error = source->error();
  r.stats = source->stats();
  return r;
}

}  // namespace rocklab::daq::test
