// The update methods of Ch. 2. The four concrete ones give the same map for a given semantics; `fastest`
// runs, per scan, whichever of them is measured fastest on the scans so far (update/method_chooser.h).
#pragma once

#include <optional>
#include <string_view>

namespace densemap::update {

enum class UpdateMethod {
  kBaseline,          ///< one forward 3D DDA per ray, OctoMap's cell sequence
  kSuperRays,         ///< Sec. 2.3.1-2.3.4
  kCullingRegion,     ///< Sec. 2.3.5: rays walked from the endpoint, stopping on entering the region
  kSuperRaysCulling,  ///< both
  kFastest            ///< the default: one of the four per scan, chosen by measured time per point
};

std::string_view toString(UpdateMethod m);
std::optional<UpdateMethod> parseMethod(std::string_view s);
/// The four concrete methods (not kFastest).
inline constexpr UpdateMethod kAllMethods[] = {UpdateMethod::kBaseline, UpdateMethod::kSuperRays,
                                               UpdateMethod::kCullingRegion, UpdateMethod::kSuperRaysCulling};

}  // namespace densemap::update
