#include "pipeline/option_error.h"

#include <sstream>

namespace rocklab::pipeline {

void Require(bool ok, const std::string& option, const std::string& what, double value) {
  if (ok) return;
  std::ostringstream msg;
  msg.precision(17);
  msg << option << " must be " << what << ", got " << value;
  throw OptionError(msg.str());
}

}  // namespace rocklab::pipeline
