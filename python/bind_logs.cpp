// rocklab.read_log, rocklab.read_raw and rocklab.info: export/ as `rocklab
// export` and `rocklab info` call it, into numpy instead of files.
#include <string>
#include <utility>
#include <vector>

#include <pybind11/stl.h>

#include "export/export.h"
#include "export/info.h"
#include "model/excitation.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "python/bindings.h"
#include "python/tables.h"

namespace rocklab::python {
namespace {

using Units = std::vector<std::pair<std::string, std::string>>;

// What a rig file gives a raw file's read (as `rocklab info/export --rig`):
// the channels' units and the rate to check the file's against.
struct RigForRaw {
  Units units;
  exporter::RawRate rate;
};
RigForRaw RigUnits(const std::string& rig_path, double rate_hz) {
  RigForRaw out;
  double rig_rate_hz = 0;
  if (!rig_path.empty()) {
    try {
      const daq::RigConfig rig = pipeline::LoadRig(rig_path);
      for (const auto& c : rig.channels) out.units.emplace_back(c.name, c.unit);
      rig_rate_hz = rig.sample_rate_hz;
    } catch (const std::exception& e) {
      ThrowIfUnreadable(rig_path, e.what());
      throw pipeline::OptionError(e.what());
    }
  }
  out.rate = exporter::ChooseRawRate(rate_hz, "rate=", rig_rate_hz, rig_path);
  return out;
}

py::dict SummaryDict(const exporter::ExportSummary& s, const std::vector<std::string>& problems) {
  py::dict d;
  py::list tables;
  for (const auto& t : s.tables) {
    py::dict row;
    row["channel"] = t.channel;
    row["type"] = t.type;
    row["rows"] = t.rows;
    row["reshaped"] = t.reshaped;
    tables.append(row);
  }
  d["tables"] = tables;
  d["rows"] = s.rows;
  d["outside_window"] = s.outside_window;
  d["filtered"] = s.filtered;
  d["unknown_type"] = s.unknown_type;
  d["undecodable"] = s.undecodable;
  d["damaged_regions"] = s.damaged_regions;
  d["damaged_bytes"] = s.damaged_bytes;
  d["damaged_events"] = s.damaged_events;
  d["bad_rows"] = s.bad_rows;
  d["bad_values"] = s.bad_values;
  d["read_error"] = s.read_error;
  d["problems"] = problems;
  return d;
}

// ExportLog or ExportRaw into numpy: (tables, summary).
py::tuple Read(bool log, const std::string& path, const std::string& channels, double start_s,
               double end_s, double rate_hz, const std::string& rig_path, const py::object& progress) {
  exporter::ExportOptions options;
  options.channels = channels;
  options.start_s = start_s;
  options.end_s = end_s;
  options.sample_rate_hz = rate_hz;
  try {
    options.Validate();
  } catch (const std::invalid_argument& e) {
    throw pipeline::OptionError(e.what());  // the CLI's usage error
  }
  std::vector<std::string> problems;
  exporter::ExportSummary summary;
  ProgressHook hook(progress, 0.0);
  NumpySink sink(&hook);
  {
    py::gil_scoped_release release;
    RigForRaw rig = RigUnits(rig_path, rate_hz);
    options.units = std::move(rig.units);
    options.sample_rate_hz = rig.rate.hz;
    options.rate_origin = rig.rate.origin;
    auto collect = [&problems](const std::string& text) { problems.push_back(text); };
    try {
      summary = RunStoppable(hook, [&] {
        return log ? exporter::ExportLog(path, options, sink, collect) : exporter::ExportRaw(path, options, sink, collect);
      });
    } catch (const exporter::InputError& e) {
      // Unreadable: OSError; readable but not what it should be (no
      // header, a rate that disagrees): ValueError, as info() says it.
      ThrowIfUnreadable(path, e.what());
      throw pipeline::OptionError(e.what());
    }
    hook.Done(static_cast<double>(sink.rows()));
  }
  py::tuple tables = sink.ToNumpy();
  return py::make_tuple(tables[0], SummaryDict(summary, problems), tables[1]);
}

py::tuple ReadLog(const std::string& path, const std::string& channels, double start_s, double end_s,
                  const py::object& progress) {
  if (!exporter::IsLcmLog(path)) {
    ThrowIfUnreadable(path, path + ": cannot open");
    throw pipeline::OptionError(path + ": not an LCM log (no sync word at its start); rocklab.read_raw reads CSV/LVM");
  }
  return Read(true, path, channels, start_s, end_s, 0.0, "", progress);
}

py::tuple ReadRaw(const std::string& path, const std::string& rig_path, double rate_hz, double start_s,
                  double end_s, const py::object& progress) {
  return Read(false, path, ".*", start_s, end_s, rate_hz, rig_path, progress);
}

// A table-acceleration record (PEER .AT2 or `time,accel` CSV) as `simulate
// --accel` and `sweep --records` read it: (time s, accel m/s^2, line).
py::tuple ReadAcceleration(const std::string& path) {
  model::AccelerationRows rows;
  ProgressHook hook(py::none(), 0.0);  // Ctrl-C
  {
    py::gil_scoped_release release;
    try {
      rows = RunStoppable(hook, [&] { return model::ReadAccelerationRows(path); });
    } catch (const std::runtime_error& e) {
      ThrowIfUnreadable(path, e.what());
      throw pipeline::OptionError(e.what());
    }
  }
  return py::make_tuple(OwnedArray(std::move(rows.time_s)), OwnedArray(std::move(rows.accel_mps2)),
                        OwnedArray(std::move(rows.line)));
}

// `rocklab info --json`'s text, for json.loads.
std::string InfoJson(const std::string& path, const std::string& rig_path, double rate_hz) {
  pipeline::Require(rate_hz >= 0, "--rate", ">= 0 Hz", rate_hz);
  ProgressHook hook(py::none(), 0.0);  // Ctrl-C
  py::gil_scoped_release release;
  try {
    return RunStoppable(hook, [&] {
      if (exporter::IsLcmLog(path)) return exporter::JsonText(exporter::ToJson(exporter::ReadLogInfo(path)));
      const RigForRaw rig = RigUnits(rig_path, rate_hz);
      return exporter::JsonText(
          exporter::ToJson(exporter::ReadRawInfo(path, rig.rate.hz, rig.units, rig.rate.origin)));
    });
  } catch (const pipeline::OptionError&) {
    throw;
  } catch (const FileError&) {
    throw;
  } catch (const py::error_already_set&) {
    throw;  // Ctrl-C's KeyboardInterrupt (RunStoppable)
  } catch (const std::exception& e) {
    ThrowIfUnreadable(path, e.what());
    throw pipeline::OptionError(e.what());  // the CLI's message without its "INPUT: "
  }
}

}  // namespace

void RegisterLogs(py::module_& m) {
  m.def("_read_log", &ReadLog, py::arg("path"), py::arg("channels"), py::arg("start"), py::arg("end"),
        py::arg("progress"));
  m.def("_read_raw", &ReadRaw, py::arg("path"), py::arg("rig"), py::arg("rate"), py::arg("start"),
        py::arg("end"), py::arg("progress"));
  m.def("_read_acceleration", &ReadAcceleration, py::arg("path"));
  m.def("_info_json", &InfoJson, py::arg("path"), py::arg("rig"), py::arg("rate"));
}

}  // namespace rocklab::python
