// An empty shared object built as liblcm.so.1: the command's bus must say
// which library did not load and which package has it (startup_test.cpp).
extern "C" __attribute__((visibility("default"))) const int rocklab_not_liblcm = 1;
