// The rocklab command's LCM: the eight liblcm functions it calls (those
// lcm-cpp.hpp's lcm::LCM calls), each forwarding to liblcm.so.1, opened at
// the first call. Linked into the command as an object of its own, these
// definitions resolve the static libraries' references, and with
// --as-needed liblcm and its glib and pcre2 are not among the command's
// libraries: `--version`, `simulate`, `fit`, ... never map them; the bus,
// the DAQ's lcm:// source and the recorder open liblcm when they create an
// lcm_t (docs/performance.md, "Start-up, fourth round"). The tests and the
// Python module link liblcm as before. A liblcm function the command starts
// calling without a forwarder here makes the link take liblcm again, which
// tests/tools/startup_test.cpp notices.
#include <dlfcn.h>

#include <cstdio>
#include <mutex>
#include <string>

#pragma GCC visibility push(hidden)  // the command's own: liblcm's stay its own
#include <lcm/lcm.h>

namespace {

constexpr const char* kLiblcm = "liblcm.so.1";

struct Liblcm {
  lcm_t* (*create)(const char*){};
  void (*destroy)(lcm_t*){};
  int (*get_fileno)(lcm_t*){};
  lcm_subscription_t* (*subscribe)(lcm_t*, const char*, lcm_msg_handler_t, void*){};
  int (*unsubscribe)(lcm_t*, lcm_subscription_t*){};
  int (*publish)(lcm_t*, const char*, const void*, unsigned int){};
  int (*handle_timeout)(lcm_t*, int){};
  int (*subscription_set_queue_capacity)(lcm_subscription_t*, int){};
  std::string error;  // why it did not load; empty when it did
};

template <typename Function>
bool Bind(void* handle, const char* name, Function& function, std::string& error) {
  function = reinterpret_cast<Function>(dlsym(handle, name));
  if (function == nullptr && error.empty()) error = std::string(kLiblcm) + " has no " + name;
  return function != nullptr;
}

Liblcm Open() {
  Liblcm lcm;
  dlerror();
  // RTLD_LOCAL: a plugin linked to liblcm loads its own reference to the
  // same object; RTLD_NOW: a missing symbol shows here, not mid-run.
  void* handle = dlopen(kLiblcm, RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    lcm.error = why != nullptr ? why : std::string(kLiblcm) + " cannot be opened";
    return lcm;
  }
  bool bound = Bind(handle, "lcm_create", lcm.create, lcm.error);
  bound &= Bind(handle, "lcm_destroy", lcm.destroy, lcm.error);
  bound &= Bind(handle, "lcm_get_fileno", lcm.get_fileno, lcm.error);
  bound &= Bind(handle, "lcm_subscribe", lcm.subscribe, lcm.error);
  bound &= Bind(handle, "lcm_unsubscribe", lcm.unsubscribe, lcm.error);
  bound &= Bind(handle, "lcm_publish", lcm.publish, lcm.error);
  bound &= Bind(handle, "lcm_handle_timeout", lcm.handle_timeout, lcm.error);
  bound &= Bind(handle, "lcm_subscription_set_queue_capacity", lcm.subscription_set_queue_capacity,
                lcm.error);
  if (!bound) lcm.create = nullptr;  // lcm_create fails; nothing else is reached
  return lcm;
}

// Opened once, by the first lcm_create (C++ statics start thread-safely).
const Liblcm& Lcm() {
  static const Liblcm lcm = Open();
  return lcm;
}

}  // namespace

extern "C" {

// Every other function takes an lcm_t or a subscription, which only a
// successful lcm_create made, so only this one meets a liblcm that did not load.
lcm_t* lcm_create(const char* provider) {
  const Liblcm& lcm = Lcm();
  if (lcm.create == nullptr) {
    static std::once_flag said;  // once, whichever thread opens a bus first
    std::call_once(said, [&lcm] {
      std::fprintf(stderr, "rocklab: the LCM bus needs %s, which does not load: %s (apt-get install liblcm1)\n",
                   kLiblcm, lcm.error.c_str());
    });
    return nullptr;
  }
  return lcm.create(provider);
}

void lcm_destroy(lcm_t* instance) { Lcm().destroy(instance); }

int lcm_get_fileno(lcm_t* instance) { return Lcm().get_fileno(instance); }

lcm_subscription_t* lcm_subscribe(lcm_t* instance, const char* channel, lcm_msg_handler_t handler,
                                  void* userdata) {
  return Lcm().subscribe(instance, channel, handler, userdata);
}

int lcm_unsubscribe(lcm_t* instance, lcm_subscription_t* subscription) {
  return Lcm().unsubscribe(instance, subscription);
}

int lcm_publish(lcm_t* instance, const char* channel, const void* data, unsigned int datalen) {
  return Lcm().publish(instance, channel, data, datalen);
}

int lcm_handle_timeout(lcm_t* instance, int timeout_millis) {
  return Lcm().handle_timeout(instance, timeout_millis);
}

int lcm_subscription_set_queue_capacity(lcm_subscription_t* subscription, int num_messages) {
  return Lcm().subscription_set_queue_capacity(subscription, num_messages);
}

}  // extern "C"

#pragma GCC visibility pop
