// Test helper for the CUDA backend's tests: skip a test that needs a GPU where none answers (CI has
// nvcc but no GPU; a build without nvcc has no backend), saying why.
#pragma once

#include <gtest/gtest.h>

#include "topo_gaussian/cuda/backend.h"

#define SKIP_WITHOUT_GPU()                                                          \
  do {                                                                              \
    if (!topo_gaussian::cudaDeviceInfo().available)                                 \
      GTEST_SKIP() << "no CUDA device: " << topo_gaussian::cudaDeviceInfo().reason; \
  } while (0)
