// The URDF import with the model it checked (urdf.cpp), for load_model_file of a .urdf, which
// would otherwise read the converted text a second time.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/urdf.hpp"

namespace kanedyn::io::detail {

/// urdf_to_model_yaml, and in `loaded` (when not null) the model parse_model_file read from
/// the returned text under `source_name`.
std::string convert_urdf(const std::string& urdf_text, const std::string& source_name,
                         const UrdfOptions& options, std::vector<std::string>* notes,
                         std::optional<ModelFile>* loaded);

}  // namespace kanedyn::io::detail
