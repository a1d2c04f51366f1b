// lib/rocklab/plugins/rocklab-hdf5.so: export's HDF5 and MAT writers and sweep's
// HDF5 readers behind tools/hdf5_plugin.h's table, so that the rocklab
// command maps HDF5, libmatio and their libraries only when a file of
// theirs is read or written.
#include <memory>
#include <string>

#include "common/logger_clock.h"
#include "export/h5_writer.h"
#include "export/mat_writer.h"
#include "sweep/results_h5.h"
#include "tools/hdf5_plugin.h"

namespace rocklab::tools {
namespace {

void ValidateH5Options(const exporter::H5WriterOptions& options) { options.Validate(); }

std::unique_ptr<exporter::TableSink> OpenH5(const std::string& path, const exporter::H5WriterOptions& options) {
  return std::make_unique<exporter::H5Writer>(path, options);
}

void DescribeH5File(exporter::TableSink& h5, const std::string& key, const std::string& value) {
  static_cast<exporter::H5Writer&>(h5).DescribeFile(key, value);  // made by OpenH5
}

std::unique_ptr<exporter::TableSink> OpenMat(const std::string& path) {
  return std::make_unique<exporter::MatWriter>(path);
}

const Hdf5Calls kCalls{kHdf5PluginVersion,           &ValidateH5Options,          &OpenH5,
                       &DescribeH5File,              &OpenMat,                    &exporter::MatWriter::Identifier,
                       &sweep::ReadResultsH5,        &sweep::ReadResultsTableH5};

}  // namespace
}  // namespace rocklab::tools

extern "C" __attribute__((visibility("default"))) const rocklab::tools::Hdf5Calls* rocklab_hdf5_plugin() {
  rocklab::common::LoadLogLevels();  // this plugin's spdlog registry
  return &rocklab::tools::kCalls;
}
