// Private: the scene loader's name for the public YAML guard (vinci/sim/model/yaml_documents.h).
#pragma once

#include <yaml-cpp/yaml.h>

#include "vinci/sim/model/yaml_documents.h"

namespace vinci::sim::internal {

using vinci::sim::LoadYamlDocuments;

}  // namespace vinci::sim::internal
