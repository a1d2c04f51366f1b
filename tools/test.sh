#!/usr/bin/env bash
# One command for the whole test suite on a fresh Debian machine: installs
# what is missing, builds, runs ctest (extra arguments go to ctest).
#
# Then, under CI=true or with ROCKLAB_ASAN_PASS=1 (ROCKLAB_ASAN_PASS=0 skips
# it), the sanitizer and fuzz pass in build-asan/: clang with AddressSanitizer,
# UndefinedBehaviorSanitizer (cmake/RocklabTargets.cmake: which checks) and
# libFuzzer's instrumentation; the whole suite once more, any sanitizer
# report failing its test; then every fuzz target of tests/fuzz for
# ROCKLAB_FUZZ_SECONDS (default 8) s on its corpus. A crash fails the run
# and leaves the input in build-asan/fuzz-artifacts/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${ROCKLAB_BUILD_DIR:-$here/build}
# CI's build goes without debug information: a quarter of the compile, and
# nobody debugs it (docs/testing.md, "Build time"); a developer's keeps it.
debug_info=ON
[ "${CI:-}" = "true" ] && debug_info=OFF
asan_pass=${ROCKLAB_ASAN_PASS:-}
if [ -z "$asan_pass" ] && [ "${CI:-}" = "true" ]; then asan_pass=1; fi
# The fuzz targets' corpus replays run in the sanitizer pass when it
# follows (under ASan and UBSan); the plain build then leaves them out.
fuzz_replay=ON
[ "$asan_pass" = "1" ] && fuzz_replay=OFF
ROCKLAB_CMAKE_ARGS="-DROCKLAB_DEBUG_INFO=$debug_info -DROCKLAB_FUZZ_REPLAY=$fuzz_replay ${ROCKLAB_CMAKE_ARGS:-}" \
  ROCKLAB_TEST_TOOLS=1 bash "$here/tools/setup.sh"

# ctest in build folder $1 (more arguments go to ctest). ctest counts a
# skipped test (GTEST_SKIP, exit code 77) as passed, so under CI=true its
# JUnit report is read and any test not run fails the run: a skip cannot
# hide in CI, whether or not it went through tests/skip.h's ROCKLAB_SKIP.
run_ctest() {
  local dir=$1
  shift
  local junit="$dir/ctest-junit.xml"
  rm -f "$junit"
  (cd "$dir" && ctest --output-on-failure -j "$(nproc)" --output-junit "$junit" "$@")
  [ "${CI:-}" = "true" ] || return 0
  python3 - "$junit" <<'PY'
import sys
import xml.etree.ElementTree as ET
cases = ET.parse(sys.argv[1]).getroot().iter("testcase")
not_run = [c.get("name") for c in cases
           if c.get("status") not in ("run", "fail") or c.find("skipped") is not None]
if not_run:
    print(f"rocklab test: CI=true and {len(not_run)} test(s) did not run (skipped):", file=sys.stderr)
    for name in not_run:
        print(f"  {name}", file=sys.stderr)
    sys.exit(1)
PY
}

run_ctest "$build" "$@"

[ "$asan_pass" = "1" ] || exit 0

asan=${ROCKLAB_ASAN_BUILD_DIR:-$here/build-asan}
# -O1 with line tables: AddressSanitizer's recommended level (the suite runs
# at a usable speed, 40 % less compile than -O3) and symbolised reports.
# No benchmarks (none runs here). Warnings are the plain build's job, and
# so is the command's lean start: here it links spdlog, fmt and toml++
# shared (ROCKLAB_COMMAND_OWN_LIBS=OFF, ~36 s less compile).
CXXFLAGS="-gline-tables-only -DNDEBUG ${CXXFLAGS:-}" ROCKLAB_BUILD_DIR=$asan \
  ROCKLAB_CMAKE_ARGS="-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE=-O1 -DROCKLAB_SANITIZE=ON -DROCKLAB_FUZZ=ON -DROCKLAB_LCM_JAVA=OFF -DROCKLAB_BENCH=OFF -DROCKLAB_WERROR=OFF -DROCKLAB_COMMAND_OWN_LIBS=OFF ${ROCKLAB_CMAKE_ARGS:-}" \
  ROCKLAB_TEST_TOOLS=1 bash "$here/tools/setup.sh"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
# Left to the plain pass: long numerical tests whose code the sanitizer
# pass still runs in smaller tests, and the stack oracle (python only).
# Which, their cost under ASan and why: docs/testing.md, "Build time".
asan_left_out_tests=(
  'External\.stack_oracle'
  'BlockTest\.AMillionVertexSectionIsCheckedInLinearlyManyEdgeTests'
  'FitTrajectory\.(ReadsTheTableRecordAsASplineAndSaysWhenItsSamplingMovesTheFit|RecoversBlock1FromAForcedTest)'
  'FitTrajectory\.(ForcedNearThresholdFindsTheTruthOrSaysNotConverged|ForcedLocalMinimumIsNotCalledConverged)'
  'FitTrajectory\.TwoMinimaTheRecordCannotTellApartAreBothSaid'
  'FitTrajectory\.(ResidualToNoiseSeesAWrongModel|ForcedFitFindsTheTruthsPieceOfARuggedCost)'
  'FitTrajectory\.CovarianceIsTheModelsSensitivityNotTheIntegratorsError'
  'SweepMerge\.ByteDamagedHdf5ShardsAreErrorsNotCrashes'
  'CliPosterior\.JsonKeysSamplesAndPlot'
  'VideoTracking\.MjpegVideoGivesThetaWithinTheBoundOfItsMeasuredPixelError'
  'Posterior\.(TrajectoryChiSquareAtTheTruthIsTheNoise|ImpactsPosteriorCoversTheTruthAndConverges|ComplexModelSamplesL)'
  'StackRun\.FiveDrumsRunToTheEndUnderTheInputsThatFailed'
  'docs_day_in_the_lab'
  'EnsembleSampler\.LinearGaussianPosteriorWithinMonteCarloError'
  'ReportBrowser\.PageDrawsThePosteriorBand'
  'MonitorBrowser\.AnAssemblyGetsAChartAndFiguresPerBody'
  'StackImpact\.EveryPassAgreesWithTheReferenceImpactRule'
  'AssemblyCli\.ImpactsResolvedWithPivotsHeldAreCountedAndSaid'
  'FitCoverage\.ImpactsStandardErrorsCoverAtTheirNominalRate'
  'VideoTracking\.TrackCsvReconstructsLikeTheVideoInputThroughTheCli'
)
asan_left_out="^($(IFS='|'; echo "${asan_left_out_tests[*]}"))\$"
run_ctest "$asan" -E "$asan_left_out" "$@"

seconds=${ROCKLAB_FUZZ_SECONDS:-8}
mkdir -p "$asan/fuzz-artifacts"
run_fuzzer() {  # target max_len seed dirs...; prints its lines at its end, at once
  local target=$1 max_len=$2
  shift 2
  local work="$asan/fuzz-corpus/$target"
  mkdir -p "$work"
  local log="$asan/fuzz-artifacts/$target.log"
  if ! "$asan/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -max_len="$max_len" -timeout=10 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$asan/fuzz-artifacts/$target-" \
      "$work" "$here/tests/fuzz/corpus/$target" "$@" >"$log" 2>&1; then
    { tail -n 60 "$log"
      echo "rocklab fuzz: $target failed; the input is in $asan/fuzz-artifacts/"; } >&2
    return 1
  fi
  printf 'rocklab fuzz: %s ran %s s (log: %s)\n%s\n' "$target" "$seconds" "$log" \
    "$(grep -E 'stat::(number_of_executed_units|peak_rss_mb)' "$log" || true)"
}
# One fuzzer per core at a time: each runs its full time, the pass takes
# half the wall time on two cores. A failure fails the run once all ended.
fuzz_running=0
fuzz_failed=0
fuzz() {
  if ((fuzz_running >= $(nproc))); then
    wait -n || fuzz_failed=1
    fuzz_running=$((fuzz_running - 1))
  fi
  run_fuzzer "$@" &
  fuzz_running=$((fuzz_running + 1))
}
fuzz csv 8192 "$here/data/samples"
fuzz lvm 8192 "$here/data/samples"
fuzz rig_config 8192 "$here/data/rigs"
fuzz live_state 4096
fuzz http 4096
fuzz lcm_log 16384
fuzz lcm_types 4096
fuzz at2 8192
fuzz daq_config 4096
fuzz polygon_csv 8192
fuzz theta_csv 16384 "$here/data/samples"
if [ -x "$asan/tests/fuzz/fuzz_rig_video" ]; then  # built with the video inputs (OpenCV)
  fuzz rig_video 8192 "$here/data/rigs"
fi
fuzz assembly 4096 "$here/data/assemblies"
fuzz sweep_csv 8192
fuzz sweep_h5 65536
while ((fuzz_running > 0)); do
  wait -n || fuzz_failed=1
  fuzz_running=$((fuzz_running - 1))
done
[ "$fuzz_failed" = 0 ] || { echo "rocklab fuzz: a fuzz target failed (above)" >&2; exit 1; }
