// Where the shipped ILN weights are found (Ch. 4): the source tree's models/iln/, or an installed
// share/densemap/models next to the program. One lookup for the server and every tool.
#pragma once

#include <string>

namespace densemap::densify {

/// The path of a shipped weights file (e.g. "iln_compact.pt"); throws std::runtime_error saying where it
/// looked and which option takes another file.
std::string shippedWeights(const std::string& file = "iln_compact.pt");

}  // namespace densemap::densify
