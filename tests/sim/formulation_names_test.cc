// The formulation name table (model/scene.h): one name per FormulationType, ParseFormulation and
// ToString are inverse, unknown names are rejected naming the accepted ones, and the scene-file
// loader accepts exactly the table's names.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>

#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::sim {
namespace {

using ::testing::HasSubstr;

TEST(FormulationNamesTest, EveryTypeHasOneNameAndParsingInvertsToString) {
  const std::vector<std::string> names = FormulationNames();
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
  std::set<FormulationType> types;
  for (const auto& [name, type] : FormulationTable()) {
    types.insert(type);
    EXPECT_EQ(ParseFormulation(name), type) << name;
    EXPECT_EQ(ToString(type), name);
  }
  // Every enumerator, kStewartTrinkle .. kGeometricallyImplicit, is in the table once.
  EXPECT_EQ(types.size(), names.size());
  EXPECT_EQ(static_cast<int>(types.size()),
            static_cast<int>(FormulationType::kGeometricallyImplicit) + 1);
}

TEST(FormulationNamesTest, UnknownNameIsRejectedNamingTheAcceptedOnes) {
  try {
    ParseFormulation("moreau");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'moreau'"));
    for (const std::string& n : FormulationNames()) EXPECT_THAT(e.what(), HasSubstr(n));
  }
}

TEST(FormulationNamesTest, SceneFileAcceptsEveryTableName) {
  for (const auto& [name, type] : FormulationTable()) {
    const Scene s = ParseScene(
        "dimension: 2\nstepper: {formulation: " + name + "}\nbodies: [{name: a, kind: static}]\n",
        "t.yaml");
    EXPECT_EQ(s.options.formulation, type) << name;
  }
}

}  // namespace
}  // namespace vinci::sim
