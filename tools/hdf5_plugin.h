#pragma once
// The HDF5 and MAT file plugin (lib/rocklab/plugins/rocklab-hdf5.so, in the rocklab
// package): export's H5Writer and MatWriter and sweep's HDF5 readers, with
// the HDF5 C library and libmatio, which Debian's builds link to libcurl,
// the TLS and Kerberos libraries (25 shared objects, ~5 ms of CPU and
// 4.5 MB at every start: docs/performance.md, Start-up). The rocklab
// command does not link them: tools/hdf5_forward.cpp defines those
// classes and functions for it, forwarding to this table, and the plugin is
// opened at the first HDF5 or MAT file read or written. Everything else
// that links rocklab::export and rocklab::sweep (the Python module, the
// tests, a program using the -dev package) has the real ones.

#include <memory>
#include <string>
#include <vector>

#include "export/h5_writer.h"
#include "export/table.h"
#include "sweep/results_h5.h"

namespace rocklab::tools {

/// The plugin's entry: `extern "C" const Hdf5Calls* rocklab_hdf5_plugin()`.
inline constexpr const char* kHdf5PluginEntry = "rocklab_hdf5_plugin";
inline constexpr const char* kHdf5PluginFile = "rocklab-hdf5.so";
/// Hdf5Calls::version of this build; a plugin with another is refused (2:
/// read_results_table replaced read_results_columns; 3: TableSink gained
/// DescribeFile, which moves its virtual table; 4: sweep::ResultRow gained
/// first_overturned_body).
inline constexpr int kHdf5PluginVersion = 4;

/// The real classes and functions of export/ and sweep/, by the same names.
struct Hdf5Calls {
  int version;
  void (*validate_h5_options)(const exporter::H5WriterOptions& options);
  std::unique_ptr<exporter::TableSink> (*open_h5)(const std::string& path, const exporter::H5WriterOptions& options);
  /// H5Writer::DescribeFile of a sink open_h5 made.
  void (*describe_h5_file)(exporter::TableSink& h5, const std::string& key, const std::string& value);
  std::unique_ptr<exporter::TableSink> (*open_mat)(const std::string& path);
  std::string (*mat_identifier)(const std::string& name);
  std::vector<sweep::ResultRow> (*read_results)(const std::string& path);
  sweep::H5ResultsTable (*read_results_table)(const std::string& path, const std::vector<std::string>& names);
};

}  // namespace rocklab::tools
