# Per-target warnings and sanitizers, shared by every rocklab target.
#
# ROCKLAB_SANITIZE: AddressSanitizer and UndefinedBehaviorSanitizer, except
#   -fno-sanitize=vptr: lcm-cpp (1.3.1) hands each subscription's handler
#   through a void* and casts it back to the handler's class inside the
#   library's template code; GCC 12's vptr check reports every such call
#   ("member call on address ... which does not point to an object of type")
#   and the node then dies in its first LCM callback, so with vptr on no
#   node test could run. The other UBSan checks (overflow, shifts, bounds,
#   float-cast-overflow, ...) stay on. Nothing else is turned off.
# ROCKLAB_FUZZ (clang): every target also carries libFuzzer's coverage
#   instrumentation (-fsanitize=fuzzer-no-link), so the fuzz targets in
#   tests/fuzz see into the libraries they call.
function(rocklab_configure_target target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
  if(ROCKLAB_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(ROCKLAB_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize=vptr
                                             -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize=vptr)
  endif()
  if(ROCKLAB_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()
