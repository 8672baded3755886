// libdensemap_iln_plugin.so: the ILN upsampler behind a C entry point, so programs load libtorch only when
// they densify with ILN (core/densify/include/densemap/densify/iln_plugin.h).
#include <cstdio>
#include <exception>
#include <memory>

#include <spdlog/spdlog.h>

#include "densemap/densify/iln_plugin.h"
#include "densemap/densify/iln_upsampler.h"

extern "C" __attribute__((visibility("default"))) densemap::densify::RangeUpsampler*
densemap_make_iln_upsampler(const char* weights, int threads, char* error, unsigned error_size) {
  static_assert(std::is_same_v<decltype(&densemap_make_iln_upsampler), densemap::densify::IlnFactory>);
  try {
    densemap::densify::IlnUpsampler::setThreads(threads);
    auto net =
        std::make_unique<densemap::densify::IlnUpsampler>(densemap::densify::IlnUpsampler::load(weights));
    spdlog::info("densify: ILN from {} ({} parameters)", weights, net->parameterCount());
    return net.release();  // the caller owns it at once (loadIlnUpsampler wraps it in a unique_ptr)
  } catch (const std::exception& e) {
    std::snprintf(error, error_size, "cannot load the ILN weights %s: %s", weights, e.what());
    return nullptr;
  }
}
