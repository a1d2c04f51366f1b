#include "tools/cli.h"

#include <sstream>

namespace rocklab::tools {

void Require(bool ok, const std::string& option, const std::string& what, double value) {
  if (ok) return;
  std::ostringstream msg;
  msg.precision(17);
  msg << option << " must be " << what << ", got " << value;
  throw UsageError(msg.str());
}

}  // namespace rocklab::tools
