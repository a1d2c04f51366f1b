#pragma once
/// @file
/// The error of a bad option value or input named by an option: the
/// pipeline library throws it naming the option (`--rig: file:line: ...`),
/// and the `rocklab` command line prints it on one line and exits 2 (it is
/// tools::UsageError).

#include <stdexcept>
#include <string>

namespace rocklab::pipeline {

class OptionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws OptionError("<option> must be <what>, got <value>") unless ok.
void Require(bool ok, const std::string& option, const std::string& what, double value);

}  // namespace rocklab::pipeline
