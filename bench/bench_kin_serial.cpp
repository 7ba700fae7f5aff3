// placeholder: filled by the kinematics work of issue 4
#include <benchmark/benchmark.h>
BENCHMARK_MAIN();
