#pragma once
// Which gipdyn this is: model files record it beside their format version,
// and every front end prints it (gipdyn --version, gipdyn.__version__,
// gipdyn_version()).

namespace gipdyn {

// The project's version, e.g. "0.1.0" (CMake's project version).
const char* version();

}  // namespace gipdyn
