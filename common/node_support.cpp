#include "common/node_support.h"

#include "common/bus.h"
#include "common/sd_notify.h"

namespace rocklab::common {

bool RunNodeLoop(Bus& bus, const std::atomic<bool>& stop, const std::function<void()>& periodic,
                 int drain_max, const std::string& log_name, int quiet_ms) {
  bool ok = true;
  NotifySystemd("READY=1");  // under systemd (Type=notify): the node is subscribed and running
  while (!stop.load()) {
    if (bus.HandleTimeout(100) < 0) {
      if (!stop.load()) {  // a stop signal interrupts the wait: not an error
        NamedLogger(log_name)->error("the bus failed to receive");
        ok = false;
      }
      break;
    }
    if (periodic) periodic();  // the node's RL_HEALTH goes out from here
    NotifyWatchdog();          // so the systemd watchdog follows the same loop
  }
  NotifySystemd("STOPPING=1");
  int dispatched = 0;
  while (dispatched < drain_max && bus.HandleTimeout(quiet_ms) > 0) ++dispatched;
  return ok;
}

}  // namespace rocklab::common
