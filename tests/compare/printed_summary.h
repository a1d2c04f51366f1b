#pragma once
/// @file
/// CompareNode::PrintSummary's table as text, for the tests that read its rows.

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "compare/compare_node.h"

namespace rocklab::test {

inline std::string PrintedSummary(const std::vector<compare::VariantSummary>& summary) {
  char* text = nullptr;
  std::size_t size = 0;
  std::FILE* out = open_memstream(&text, &size);
  if (out == nullptr) {
    ADD_FAILURE() << "open_memstream failed";
    return {};
  }
  compare::CompareNode::PrintSummary(summary, out);
  std::fclose(out);
  std::string table(text, size);
  std::free(text);
  return table;
}

}  // namespace rocklab::test
