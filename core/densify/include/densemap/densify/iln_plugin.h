// The ILN upsampler (Ch. 4) as a plugin: libtorch is linked only into libdensemap_iln_plugin.so, which a
// program loads (dlopen) when it densifies with ILN. Every other program, the server with densify off
// included, neither links nor maps libtorch (an idle server was 212 MB resident with it linked).
#pragma once

#include <memory>
#include <string>

#include "densemap/densify/range_upsampler.h"

namespace densemap::densify {

/// Loads the plugin (once per process; it stays loaded) and builds an ILN upsampler from the weights with
/// `threads` inference threads. Throws std::runtime_error saying where the plugin was looked for, or why
/// the weights could not be read.
std::unique_ptr<RangeUpsampler> loadIlnUpsampler(const std::string& weights, int threads);

/// The plugin's entry point (extern "C" in the plugin): an upsampler, or null with `error` filled.
using IlnFactory = RangeUpsampler* (*)(const char* weights, int threads, char* error, unsigned error_size);
inline constexpr const char* kIlnFactorySymbol = "densemap_make_iln_upsampler";
inline constexpr const char* kIlnPluginFile = "libdensemap_iln_plugin.so";

}  // namespace densemap::densify
