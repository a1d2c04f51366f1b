// The rocklab command's export::H5Writer, export::MatWriter and sweep's
// HDF5 readers: the same classes and functions as export/h5_writer.cpp,
// export/mat_writer.cpp and sweep/results_h5.cpp, each forwarding to the
// HDF5 plugin (tools/hdf5_plugin.h), opened at the first call. Linked into
// the command as an object of its own, these definitions come before the
// static libraries', so the linker never takes h5_writer.o, mat_writer.o
// or results_h5.o from the archives (IsHdf5File is plot.cpp's), and with --as-needed HDF5 and matio
// are not among the command's libraries (tests/tools/startup_test.cpp
// checks that). A symbol of those files missing here would pull its
// object in and fail the link with a duplicate definition.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/plugin.h"
#include "export/h5_writer.h"
#include "export/mat_writer.h"
#include "sweep/results_h5.h"
#include "tools/hdf5_plugin.h"

namespace rocklab {
namespace tools {
namespace {

const Hdf5Calls& Hdf5() {
  std::string error;
  const Hdf5Calls* calls =
      common::OpenPluginOnce<Hdf5Calls>(kHdf5PluginFile, kHdf5PluginEntry, kHdf5PluginVersion, error);
  if (calls == nullptr) {
    throw std::runtime_error("HDF5 and MAT files are read and written by rocklab's plugin " +
                             common::PluginPath(kHdf5PluginFile) + ", which does not load: " + error +
                             " (apt-get install --reinstall rocklab)");
  }
  return *calls;
}

}  // namespace
}  // namespace tools

namespace exporter {

void H5WriterOptions::Validate() const { tools::Hdf5().validate_h5_options(*this); }

struct H5Writer::Impl {
  std::unique_ptr<TableSink> sink;
};

H5Writer::H5Writer(const std::string& path, H5WriterOptions options)
    : impl_(new Impl{tools::Hdf5().open_h5(path, options)}) {}
H5Writer::~H5Writer() = default;
int H5Writer::AddTable(const std::string& name, const std::vector<Column>& columns) {
  return impl_->sink->AddTable(name, columns);
}
void H5Writer::Append(int table, const Row& row) { impl_->sink->Append(table, row); }
void H5Writer::Describe(int table, const std::string& key, const std::string& value) {
  impl_->sink->Describe(table, key, value);
}
void H5Writer::DescribeFile(const std::string& key, const std::string& value) {
  tools::Hdf5().describe_h5_file(*impl_->sink, key, value);
}
void H5Writer::Close() { impl_->sink->Close(); }
std::vector<std::string> H5Writer::files() const { return impl_->sink->files(); }

struct MatWriter::Impl {
  std::unique_ptr<TableSink> sink;
};

MatWriter::MatWriter(const std::string& path) : impl_(new Impl{tools::Hdf5().open_mat(path)}) {}
MatWriter::~MatWriter() = default;
std::string MatWriter::Identifier(const std::string& name) { return tools::Hdf5().mat_identifier(name); }
int MatWriter::AddTable(const std::string& name, const std::vector<Column>& columns) {
  return impl_->sink->AddTable(name, columns);
}
void MatWriter::Append(int table, const Row& row) { impl_->sink->Append(table, row); }
void MatWriter::DescribeFile(const std::string& key, const std::string& value) { impl_->sink->DescribeFile(key, value); }
void MatWriter::Close() { impl_->sink->Close(); }
std::vector<std::string> MatWriter::files() const { return impl_->sink->files(); }

}  // namespace exporter

namespace sweep {

std::vector<ResultRow> ReadResultsH5(const std::string& path) { return tools::Hdf5().read_results(path); }

H5ResultsTable ReadResultsTableH5(const std::string& path, const std::vector<std::string>& names) {
  return tools::Hdf5().read_results_table(path, names);
}

}  // namespace sweep
}  // namespace rocklab
