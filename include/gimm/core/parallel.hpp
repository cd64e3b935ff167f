#pragma once
/// parallel_for: OpenMP loop over [begin, end) with a static schedule.
///
/// Results are independent of the thread count as long as each iteration writes only its own
/// outputs and draws randomness from Rng::fork(i), never from a shared generator.
/// Exceptions thrown inside the body are captured and the first one is rethrown on the calling
/// thread after the loop (OpenMP forbids exceptions escaping a parallel region).
#include <cstdint>
#include <exception>
#include <mutex>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace gimm {

/// Number of threads parallel_for will use.
inline int max_threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

template <class Body>
void parallel_for(std::int64_t begin, std::int64_t end, Body&& body,
                  std::int64_t serial_below = 2) {
  if (end - begin < serial_below) {
    for (std::int64_t i = begin; i < end; ++i) body(i);
    return;
  }
  std::exception_ptr first_error;
  std::mutex error_mutex;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = begin; i < end; ++i) {
    try {
      body(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!first_error) first_error = std::current_exception();
    }
  }
  if (first_error) std::rethrow_exception(first_error);
}

/// Same, with dynamic scheduling in chunks of `chunk` iterations, for uneven work
/// (rays of different lengths). Still deterministic when each iteration owns its outputs.
template <class Body>
void parallel_for_dynamic(std::int64_t begin, std::int64_t end, std::int64_t chunk, Body&& body) {
  std::exception_ptr first_error;
  std::mutex error_mutex;
#pragma omp parallel for schedule(dynamic, chunk)
  for (std::int64_t i = begin; i < end; ++i) {
    try {
      body(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!first_error) first_error = std::current_exception();
    }
  }
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace gimm
